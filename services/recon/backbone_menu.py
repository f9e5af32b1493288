"""Which backbones this installation can run now, and why not: the truth behind `/v1/backbones`.

Learned backbones are available when their checkpoint is found (explicit path setting, else the
hub cache) and, for safetensors files, its header fits the architecture; nothing is loaded to
find out. `auto` is Pi3X when available, else VGGT, else classical.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache

from services.recon.backbones.base import available_backbones
from services.recon.checkpoints import CATALOGUE, WeightsError, locate, verify
from shared.wire.settings import ReconSettings

AUTO = "auto"
AUTO_ORDER = ("pi3x", "vggt", "classical")
POSED_RGBD_NOTE = "needs depth maps and cameras with the upload (in metres)"


@dataclass(frozen=True)
class BackboneAvailability:
    name: str
    available: bool
    reason: str | None  # why not, with what to run; None when available
    units: str  # "metres" or "relative"
    device: str
    note: str | None = None  # what it needs from an upload, where it says more than the name

    @property
    def refusal(self) -> str:
        return f"backbone {self.name} is not available here: {self.reason}"


@lru_cache(maxsize=8)
def learned_device(setting: str | None) -> str:
    """Where a learned backbone would run: the setting, else cuda when torch sees a GPU, else cpu."""
    if setting:
        return setting
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


@lru_cache(maxsize=32)
def _header_problems(name: str, path: str, size: int, mtime_ns: int, config: str | None) -> tuple[str, ...]:
    """Cached per file version (size and mtime), so the menu reads each header once."""
    try:
        return tuple(verify(name, path, config))
    except WeightsError as error:
        return (str(error),)


def learned_availability(name: str, settings: ReconSettings) -> BackboneAvailability:
    entry = CATALOGUE[name]
    explicit = getattr(settings, f"{name}_checkpoint")
    config = getattr(settings, f"{name}_config")
    path, how = locate(name, explicit, settings.weights_revision)
    device = learned_device(settings.device)
    if path is None:
        return BackboneAvailability(name, False, how, entry.units, device)
    if path.suffix.lower() == ".safetensors":
        stat = os.stat(path)
        problems = _header_problems(
            name, str(path), stat.st_size, stat.st_mtime_ns, str(config) if config else None
        )
        if problems:
            reason = f"the checkpoint {path} does not fit the architecture ({'; '.join(problems)[:300]})"
            fix = "set the right path" if explicit else f"run `{entry.pull_command}` again"
            return BackboneAvailability(name, False, f"{reason}; {fix}", entry.units, device)
    return BackboneAvailability(name, True, None, entry.units, device)


def availability(name: str, settings: ReconSettings) -> BackboneAvailability:
    if name in CATALOGUE:
        return learned_availability(name, settings)
    if name == "posed-rgbd":
        return BackboneAvailability(name, True, None, "metres", "cpu", POSED_RGBD_NOTE)
    return BackboneAvailability(name, True, None, "relative", "cpu")


def backbone_menu(settings: ReconSettings) -> list[BackboneAvailability]:
    """Every registered backbone with its availability, in registry order."""
    return [availability(name, settings) for name in available_backbones()]


def resolve_auto(settings: ReconSettings) -> str:
    """The backbone `auto` stands for now: the first available of AUTO_ORDER."""
    for name in AUTO_ORDER:
        if availability(name, settings).available:
            return name
    return "classical"
