"""The published checkpoints of the learned backbones: where they are, whether they fit, how to get them.

Files live in the Hugging Face hub cache (`HF_HOME` / `HF_HUB_CACHE`, as huggingface_hub defines
them) under their repository; `pyspatial weights pull NAME` puts them there. The recon service
only ever looks in the cache (no network at request time); an explicit path setting wins.
`HF_ENDPOINT` (another hub or a mirror) and `HF_HUB_OFFLINE` behave as the library defines them.

Verification reads tensor names and shapes without loading the weights: the safetensors header,
or for VGGT's `.pt` a memory-mapped `torch.load` (the tensors are mapped, not read).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

# Imported with the service, not on the first /v1/backbones request (it takes a second or more).
from huggingface_hub import try_to_load_from_cache

if TYPE_CHECKING:  # torch loads only when a checkpoint is read: the service starts without it
    from torch import nn

Shapes = dict[str, tuple[int, ...]]


@dataclass(frozen=True)
class PublishedCheckpoint:
    backbone: str
    repo_id: str
    filename: str
    units: str  # what the backbone's reconstructions are measured in

    @property
    def pull_command(self) -> str:
        return f"pyspatial weights pull {self.backbone}"


CATALOGUE: dict[str, PublishedCheckpoint] = {
    "vggt": PublishedCheckpoint("vggt", "facebook/VGGT-1B", "model.pt", "relative"),
    "pi3": PublishedCheckpoint("pi3", "yyfz233/Pi3", "model.safetensors", "relative"),
    "pi3x": PublishedCheckpoint("pi3x", "yyfz233/Pi3X", "model.safetensors", "metres"),
}


WEIGHTS_ABSENT = "weights not present"


class WeightsError(RuntimeError):
    """A checkpoint cannot be pulled, found or verified; the message says what to do."""


def published(name: str) -> PublishedCheckpoint:
    if name not in CATALOGUE:
        raise WeightsError(f"no published checkpoint for {name!r}; known: {', '.join(CATALOGUE)}")
    return CATALOGUE[name]


def hub_endpoint() -> str:
    from huggingface_hub import constants

    return constants.ENDPOINT


def cached_path(name: str, revision: str = "main") -> Path | None:
    """The pulled file in the hub cache, or None. Never touches the network."""
    entry = published(name)
    found = try_to_load_from_cache(entry.repo_id, entry.filename, revision=revision)
    return Path(found) if isinstance(found, str) and Path(found).is_file() else None


def locate(name: str, explicit: str | os.PathLike | None, revision: str = "main") -> tuple[Path | None, str]:
    """(path, how it was found) for a backbone's checkpoint: the explicit setting, else the hub cache.

    The path is None when there is none; the text then says what to run.
    """
    if explicit:
        path = Path(explicit)
        if path.is_file():
            return path, f"set path {path}"
        return None, f"{WEIGHTS_ABSENT}: the configured checkpoint {path} does not exist"
    found = cached_path(name, revision)
    if found is not None:
        return found, f"hub cache ({published(name).repo_id}@{revision})"
    return None, f"{WEIGHTS_ABSENT}: run `{published(name).pull_command}`"


def checkpoint_shapes(path: str | os.PathLike) -> Shapes:
    """Tensor names and shapes of a checkpoint without reading its weights into memory."""
    import torch

    path = Path(path)
    try:
        if path.suffix.lower() == ".safetensors":
            from safetensors import safe_open

            with safe_open(str(path), framework="pt") as handle:
                return {name: tuple(handle.get_slice(name).get_shape()) for name in handle.keys()}
        state = torch.load(path, map_location="cpu", weights_only=True, mmap=True)
    except Exception as error:  # corrupt files raise many types
        raise WeightsError(f"cannot read checkpoint {path}: {error}") from error
    if isinstance(state, dict) and isinstance(state.get("model"), dict):
        state = state["model"]
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise WeightsError(f"checkpoint {path} is not a state dict of tensors")
    return {name: tuple(tensor.shape) for name, tensor in state.items()}


def _meta_shapes(build: Callable[[], nn.Module]) -> Shapes:
    import torch

    with torch.device("meta"):
        model = build()
    return {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}


def architecture_problems(name: str, given: Shapes, config_path: str | None = None) -> list[str]:
    """What does not fit between a checkpoint's tensors and the backbone's architecture (empty: fits)."""
    from services.recon.backbones.transformer.checkpoint import shape_problems

    if name == "vggt":
        from services.recon.backbones.vggt.checkpoint import IGNORED_PREFIXES
        from services.recon.backbones.vggt.config import VGGTConfig
        from services.recon.backbones.vggt.model import VGGT

        config = VGGTConfig.from_json(config_path) if config_path else VGGTConfig()
        return shape_problems(_meta_shapes(lambda: VGGT(config)), given, IGNORED_PREFIXES)
    from services.recon.backbones.pi3.checkpoint import has_conditioning
    from services.recon.backbones.pi3.config import Pi3Config
    from services.recon.backbones.pi3.config_file import read_pi3_config
    from services.recon.backbones.pi3.model import Pi3, Pi3X

    config = read_pi3_config(config_path) if config_path else Pi3Config.full_size(name)  # type: ignore[arg-type]
    if name == "pi3":
        return shape_problems(_meta_shapes(lambda: Pi3(config)), given)
    multimodal = has_conditioning(config, set(given))
    ignored = () if multimodal else config.multimodal_prefixes
    return shape_problems(_meta_shapes(lambda: Pi3X(config, multimodal=multimodal)), given, ignored)


def verify(name: str, path: str | os.PathLike, config_path: str | None = None) -> list[str]:
    """`architecture_problems` of the file at `path` (reads names and shapes only)."""
    return architecture_problems(name, checkpoint_shapes(path), config_path)


def pull(name: str, revision: str = "main") -> Path:
    """Download a backbone's published file into the hub cache (progress on stderr) and return it.

    huggingface_hub resumes a download whose connection drops (HTTP range requests) and keeps
    the cache consistent; a file already in the cache at that revision is not fetched again.
    """
    from huggingface_hub import constants, hf_hub_download
    from huggingface_hub.errors import (
        HfHubHTTPError,
        LocalEntryNotFoundError,
        OfflineModeIsEnabled,
        RemoteEntryNotFoundError,
        RepositoryNotFoundError,
        RevisionNotFoundError,
    )

    entry = published(name)
    where = f"{entry.repo_id}/{entry.filename}@{revision}"
    try:
        return Path(hf_hub_download(entry.repo_id, entry.filename, revision=revision))
    except (RepositoryNotFoundError, RevisionNotFoundError, RemoteEntryNotFoundError) as error:
        raise WeightsError(
            f"the model hub at {constants.ENDPOINT} has no {where}: {_first_line(error)}"
        ) from error
    except (OfflineModeIsEnabled, LocalEntryNotFoundError) as error:
        if constants.is_offline_mode():
            raise WeightsError(f"HF_HUB_OFFLINE is set and {where} is not in the hub cache") from error
        raise WeightsError(
            f"cannot reach the model hub at {constants.ENDPOINT} to download {where} (no network? "
            "set HF_ENDPOINT to a reachable hub or mirror)"
        ) from error
    except HfHubHTTPError as error:
        raise WeightsError(
            f"the model hub at {constants.ENDPOINT} refused {where}: {_first_line(error)}"
        ) from error
    except OSError as error:
        raise WeightsError(
            f"cannot store {where} in the hub cache {constants.HF_HUB_CACHE}: {error}"
        ) from error


def remove_from_cache(path: Path) -> None:
    """Delete a pulled file (the snapshot link and the blob it points to), so nothing finds it again."""
    blob = path.resolve()
    path.unlink(missing_ok=True)
    if blob != path:
        blob.unlink(missing_ok=True)


def _first_line(error: Exception) -> str:
    return str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
