"""The `--backbone` option of the commands that reconstruct: only what the service can run now."""

from __future__ import annotations

from cli.console import EXIT_USAGE, fail

BACKBONE_HELP = (
    "classical, posed-rgbd, vggt, pi3, pi3x or auto (Pi3X when its weights are present, then VGGT, then "
    "classical); the service's default when unset. Only backbones the service can run are accepted."
)


def check_backbone(menu: dict, name: str | None) -> None:
    """Refuse, before uploading anything, a backbone the service says it cannot run (and say why)."""
    if name is None or name in menu.get("available", []):
        return
    entries = {entry["name"]: entry for entry in menu.get("backbones", [])}
    offered = ", ".join(menu.get("available", []))
    if name in entries and entries[name].get("reason"):
        raise fail(f"backbone {name} is not available on this service: {entries[name]['reason']}", EXIT_USAGE)
    raise fail(f"unknown backbone {name!r}; this service offers: {offered}", EXIT_USAGE)
