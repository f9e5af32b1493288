"""3D backbones: each turns a list of RGB images into a `Reconstruction`."""

from services.recon.backbones.base import Backbone, BackboneError, available_backbones, create_backbone

__all__ = ["Backbone", "BackboneError", "available_backbones", "create_backbone"]
