"""What a route may ask for: the app's one `SolvePipeline` and its settings (on `app.state`)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from services.agent.pipeline import SolvePipeline
from shared.wire.settings import AgentSettings


def solve_pipeline(request: Request) -> SolvePipeline:
    return request.app.state.pipeline


def agent_settings(request: Request) -> AgentSettings:
    return request.app.state.settings


PipelineDep = Annotated[SolvePipeline, Depends(solve_pipeline)]
SettingsDep = Annotated[AgentSettings, Depends(agent_settings)]
