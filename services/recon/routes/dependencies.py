"""What a route may ask for: the app's one `ReconService` and its upload parser (on `app.state`)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from services.recon.service import ReconService
from services.recon.uploads import SceneUploads


def recon_service(request: Request) -> ReconService:
    return request.app.state.service


def scene_uploads(request: Request) -> SceneUploads:
    return request.app.state.uploads


ServiceDep = Annotated[ReconService, Depends(recon_service)]
UploadsDep = Annotated[SceneUploads, Depends(scene_uploads)]
