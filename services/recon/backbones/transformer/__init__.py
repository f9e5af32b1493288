"""Transformer parts that VGGT and Pi3 share: DINOv2 with registers, attention, 2D RoPE, blocks,
checkpoint reading and strict loading. One copy, so a fix reaches both models."""
