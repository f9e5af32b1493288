"""Imaging: decode, validate and encode image files; camera intrinsics from their EXIF tags.

Bytes in, arrays out. Imports nothing from the other layers of `shared`.
"""
