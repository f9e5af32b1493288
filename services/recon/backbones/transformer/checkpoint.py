"""Read a checkpoint (.pt state dict or .safetensors) and load it strictly into a model; read a
model's JSON configuration file.

A missing, unexpected or mis-shaped tensor is an error that lists what is wrong; only tensors
under the prefixes a model declares optional may be absent (or present without a place).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TypeVar

import torch
from torch import nn

from services.recon.backbones.base import BackboneError

LISTED_PER_PROBLEM = 20  # enough to see the pattern without flooding a log line
ModelT = TypeVar("ModelT", bound=nn.Module)


def read_state_dict(path: str | Path, what: str = "checkpoint") -> dict[str, torch.Tensor]:
    """Tensors of a checkpoint file on the CPU. Raises BackboneError for missing or unreadable files."""
    path = Path(path)
    if not path.is_file():
        raise BackboneError(f"{what} {path} does not exist")
    suffix = path.suffix.lower()
    try:
        if suffix == ".safetensors":
            from safetensors.torch import load_file

            state = load_file(str(path), device="cpu")
        elif suffix in (".pt", ".pth"):
            state = torch.load(path, map_location="cpu", weights_only=True)
        else:
            raise BackboneError(f"{what} {path} must be a .pt, .pth or .safetensors file")
    except BackboneError:
        raise
    except Exception as error:  # torch and safetensors raise many types for corrupt files
        raise BackboneError(f"cannot read {what} {path}: {error}") from error
    if isinstance(state, Mapping) and "model" in state and isinstance(state["model"], Mapping):
        state = state["model"]  # training checkpoints wrap the weights
    if not isinstance(state, Mapping) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise BackboneError(f"{what} {path} is not a state dict of tensors")
    return dict(state)


def _listing(title: str, names: list[str]) -> str:
    shown = ", ".join(names[:LISTED_PER_PROBLEM])
    more = f" (and {len(names) - LISTED_PER_PROBLEM} more)" if len(names) > LISTED_PER_PROBLEM else ""
    return f"{len(names)} {title}: {shown}{more}"


def shape_problems(
    expected: Mapping[str, tuple[int, ...]],
    given: Mapping[str, tuple[int, ...]],
    ignored_prefixes: tuple[str, ...] = (),
) -> list[str]:
    """Human-readable mismatches between the shapes a model has and a checkpoint's; empty when they agree.

    Names under `ignored_prefixes` are left out on both sides (optional parts of an architecture).
    """
    expected = {n: s for n, s in expected.items() if not n.startswith(ignored_prefixes)}
    given = {n: s for n, s in given.items() if not n.startswith(ignored_prefixes)}
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


def state_dict_problems(
    model: nn.Module, state: Mapping[str, torch.Tensor], ignored_prefixes: tuple[str, ...] = ()
) -> list[str]:
    """`shape_problems` between a model's tensors and a loaded checkpoint's."""
    expected = {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}
    given = {name: tuple(tensor.shape) for name, tensor in state.items()}
    return shape_problems(expected, given, ignored_prefixes)


def load_strictly(
    build: Callable[[], ModelT],
    checkpoint: str | Path,
    what: str,
    device: torch.device | str = "cpu",
    ignored_prefixes: tuple[str, ...] = (),
) -> ModelT:
    """Read the checkpoint and `fill_strictly` a model from it."""
    state = read_state_dict(checkpoint, what)
    return fill_strictly(build, state, f"{what} {checkpoint}", device, ignored_prefixes)


def fill_strictly(
    build: Callable[[], ModelT],
    state: Mapping[str, torch.Tensor],
    source: str,
    device: torch.device | str = "cpu",
    ignored_prefixes: tuple[str, ...] = (),
) -> ModelT:
    """Build the model on the meta device (no random weights) and fill it from a state dict.

    Every tensor the model has must come from the state with its shape; tensors are float32 on
    `device` and the model is in eval mode. `source` names the checkpoint in the error.
    """
    with torch.device("meta"):
        model = build()
    problems = state_dict_problems(model, state, ignored_prefixes)
    if problems:
        raise BackboneError(f"{source} does not fit the model: " + "; ".join(problems))
    wanted = set(model.state_dict())
    weights = {
        name: tensor.to(device=device, dtype=torch.float32)
        for name, tensor in state.items()
        if name in wanted
    }
    model.load_state_dict(weights, strict=True, assign=True)
    return model.eval()


def file_digest(path: str | Path, chunk_bytes: int = 16 << 20) -> str:
    """sha256 hex digest of a file, read in chunks (checkpoints are gigabytes)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(chunk_bytes):
            digest.update(chunk)
    return digest.hexdigest()


def weights_id(path: str | Path) -> str:
    """A short id of a checkpoint's content: the hub cache names its blobs by their sha256, so a
    pulled file needs no hashing again; any other file is hashed (checkpoints are gigabytes)."""
    resolved = Path(path).resolve()
    if resolved.parent.name == "blobs" and len(resolved.name) == 64:
        return resolved.name[:12]
    return file_digest(resolved)[:12]


def read_json_object(path: str | Path, what: str, error: type[Exception]) -> dict:
    """A JSON object from a model configuration file; `error` (with the reason) when it is not one."""
    try:
        values = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as problem:
        raise error(f"cannot read {what} {path}: {problem}") from problem
    if not isinstance(values, dict):
        raise error(f"{what} {path} is not a JSON object")
    return values
