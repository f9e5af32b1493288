"""Read a VGGT checkpoint (.pt state dict or .safetensors) and load it strictly into a model.

Only the tracking head's tensors (track_head.*) may be present without a place in the model; any
other missing, unexpected or mis-shaped tensor is an error that lists what is wrong.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path

import torch
from torch import nn

from services.recon.backbones.base import BackboneError
from services.recon.backbones.vggt.config import VGGTConfig
from services.recon.backbones.vggt.model import VGGT

IGNORED_PREFIXES = ("track_head.",)
LISTED_PER_PROBLEM = 20  # enough to see the pattern without flooding a log line


def read_state_dict(path: str | Path) -> dict[str, torch.Tensor]:
    """Tensors of a checkpoint file on the CPU. Raises BackboneError for missing or unreadable files."""
    path = Path(path)
    if not path.is_file():
        raise BackboneError(f"VGGT checkpoint {path} does not exist")
    suffix = path.suffix.lower()
    try:
        if suffix == ".safetensors":
            from safetensors.torch import load_file

            state = load_file(str(path), device="cpu")
        elif suffix in (".pt", ".pth"):
            state = torch.load(path, map_location="cpu", weights_only=True)
        else:
            raise BackboneError(f"VGGT checkpoint {path} must be a .pt, .pth or .safetensors file")
    except BackboneError:
        raise
    except Exception as error:  # torch and safetensors raise many types for corrupt files
        raise BackboneError(f"cannot read VGGT checkpoint {path}: {error}") from error
    if isinstance(state, Mapping) and "model" in state and isinstance(state["model"], Mapping):
        state = state["model"]  # training checkpoints wrap the weights
    if not isinstance(state, Mapping) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise BackboneError(f"VGGT checkpoint {path} is not a state dict of tensors")
    return dict(state)


def _listing(title: str, names: list[str]) -> str:
    shown = ", ".join(names[:LISTED_PER_PROBLEM])
    more = f" (and {len(names) - LISTED_PER_PROBLEM} more)" if len(names) > LISTED_PER_PROBLEM else ""
    return f"{len(names)} {title}: {shown}{more}"


def state_dict_problems(model: nn.Module, state: Mapping[str, torch.Tensor]) -> list[str]:
    """Human-readable mismatches between a model's tensors and a checkpoint's; empty when they agree."""
    expected = {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}
    given = {
        name: tuple(tensor.shape) for name, tensor in state.items() if not name.startswith(IGNORED_PREFIXES)
    }
    missing = sorted(set(expected) - set(given))
    unexpected = sorted(set(given) - set(expected))
    misshaped = sorted(
        f"{name} {given[name]} (model expects {expected[name]})"
        for name in set(expected) & set(given)
        if expected[name] != given[name]
    )
    problems = []
    if missing:
        problems.append(_listing("missing tensors", missing))
    if unexpected:
        problems.append(_listing("unexpected tensors", unexpected))
    if misshaped:
        problems.append(_listing("tensors with the wrong shape", misshaped))
    return problems


def load_vggt(checkpoint: str | Path, config: VGGTConfig, device: torch.device | str = "cpu") -> VGGT:
    """Build the model without allocating random weights and fill it from the checkpoint (float32, eval)."""
    state = read_state_dict(checkpoint)
    with torch.device("meta"):
        model = VGGT(config)
    problems = state_dict_problems(model, state)
    if problems:
        raise BackboneError(f"VGGT checkpoint {checkpoint} does not fit the model: " + "; ".join(problems))
    weights = {
        name: tensor.to(device=device, dtype=torch.float32)
        for name, tensor in state.items()
        if not name.startswith(IGNORED_PREFIXES)
    }
    model.load_state_dict(weights, strict=True, assign=True)
    # The patch embedder's mask token is only used in training; keep it frozen as published.
    model.aggregator.patch_embed.mask_token.requires_grad_(False)
    return model.eval()


def file_digest(path: str | Path, chunk_bytes: int = 16 << 20) -> str:
    """sha256 hex digest of a file, read in chunks (checkpoints are gigabytes)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(chunk_bytes):
            digest.update(chunk)
    return digest.hexdigest()
