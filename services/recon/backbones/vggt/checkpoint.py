"""Load a VGGT checkpoint (.pt state dict or .safetensors) strictly into a model.

Only the tracking head's tensors (track_head.*) may be present without a place in the model; any
other missing, unexpected or mis-shaped tensor is an error that lists what is wrong.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import torch
from torch import nn

from services.recon.backbones.transformer import checkpoint as strict
from services.recon.backbones.transformer.checkpoint import file_digest
from services.recon.backbones.vggt.config import VGGTConfig
from services.recon.backbones.vggt.model import VGGT

IGNORED_PREFIXES = ("track_head.",)
WHAT = "VGGT checkpoint"

__all__ = ["IGNORED_PREFIXES", "file_digest", "load_vggt", "read_state_dict", "state_dict_problems"]


def read_state_dict(path: str | Path) -> dict[str, torch.Tensor]:
    """Tensors of a checkpoint file on the CPU. Raises BackboneError for missing or unreadable files."""
    return strict.read_state_dict(path, WHAT)


def state_dict_problems(model: nn.Module, state: Mapping[str, torch.Tensor]) -> list[str]:
    """Human-readable mismatches between a model's tensors and a checkpoint's; empty when they agree."""
    return strict.state_dict_problems(model, state, IGNORED_PREFIXES)


def load_vggt(checkpoint: str | Path, config: VGGTConfig, device: torch.device | str = "cpu") -> VGGT:
    """Build the model without allocating random weights and fill it from the checkpoint (float32, eval)."""
    model = strict.load_strictly(lambda: VGGT(config), checkpoint, WHAT, device, IGNORED_PREFIXES)
    # The patch embedder's mask token is only used in training; keep it frozen as published.
    model.aggregator.patch_embed.mask_token.requires_grad_(False)
    return model
