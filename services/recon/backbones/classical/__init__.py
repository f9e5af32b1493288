"""The `classical` backbone: weight-free multi-view reconstruction with OpenCV."""

from .backbone import ClassicalBackbone

__all__ = ["ClassicalBackbone"]
