"""Load Pi3 / Pi3X checkpoints (.safetensors or .pt) strictly.

Every tensor of the model must come from the checkpoint with its shape, and nothing else may be
there. Pi3X's conditioning branch (depth encoder, ray embedding, pose injection) is optional, as
published: a checkpoint without any of its tensors loads an images-only model; one with only
some of them is an error that lists the missing ones.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import torch

from services.recon.backbones.pi3.config import Pi3Config
from services.recon.backbones.pi3.model import Pi3, Pi3X
from services.recon.backbones.transformer import checkpoint as strict


def has_conditioning(config: Pi3Config, names: Mapping[str, object] | set[str]) -> bool:
    """Whether a checkpoint's tensor names include any of Pi3X's conditioning branch."""
    prefixes = config.multimodal_prefixes
    return bool(prefixes) and any(name.startswith(prefixes) for name in names)


def load_pi3(checkpoint: str | Path, config: Pi3Config, device: torch.device | str = "cpu") -> Pi3 | Pi3X:
    """The model `config.arch` names, filled from the checkpoint (float32, eval mode)."""
    what = f"{'Pi3X' if config.arch == 'pi3x' else 'Pi3'} checkpoint"
    if config.arch == "pi3":
        return strict.load_strictly(lambda: Pi3(config), checkpoint, what, device)
    state = strict.read_state_dict(checkpoint, what)
    multimodal = has_conditioning(config, state)
    ignored = () if multimodal else config.multimodal_prefixes
    return strict.fill_strictly(
        lambda: Pi3X(config, multimodal=multimodal), state, f"{what} {checkpoint}", device, ignored
    )
