"""Our own PyTorch VGGT (Visual Geometry Grounded Transformer) that loads the published VGGT-1B weights.

`model.VGGT` is the network, `checkpoint.load_vggt` fills it from a checkpoint, `geometry` decodes
its outputs into cameras and world points, and `backbone.VGGTBackbone` serves it to the recon
service (imported lazily by the backbone registry).
"""

from services.recon.backbones.vggt.config import VGGTConfig, VGGTConfigError
from services.recon.backbones.vggt.geometry import pose_encoding_to_cameras, unproject_depth_maps
from services.recon.backbones.vggt.model import VGGT

__all__ = ["VGGT", "VGGTConfig", "VGGTConfigError", "pose_encoding_to_cameras", "unproject_depth_maps"]
