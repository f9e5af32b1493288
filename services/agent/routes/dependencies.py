"""What a route may ask for: the app's one `SolvePipeline` and its settings (on `app.state`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any

from fastapi import Depends, Request

from services.agent.pipeline import SolvePipeline
from shared.wire.settings import AgentSettings


def _on_app_state(name: str) -> Callable[[Request], Any]:
    """A dependency that reads `app.state.<name>` (create_app puts it there)."""

    def read(request: Request) -> Any:
        return getattr(request.app.state, name)

    return read


PipelineDep = Annotated[SolvePipeline, Depends(_on_app_state("pipeline"))]
SettingsDep = Annotated[AgentSettings, Depends(_on_app_state("settings"))]
