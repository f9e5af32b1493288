"""Geometry: camera poses, the `Reconstruction` type, camera motion, rendering, back-projection.

Pure numpy on the project's one convention (3x4 camera-from-world [R|t], OpenCV axes, intrinsics
in pixels). Imports nothing from the other layers of `shared` but itself.
"""
