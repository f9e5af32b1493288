"""Python clients of the two services (httpx). Errors carry the service's own message.

The recon client retries its calls (all idempotent: scenes are content-addressed, reconstructions
cached by scene) on a reset or refused connection and on 502/503, with exponential backoff and
jitter, honouring Retry-After, and never past its retry window: a replica restarting or nginx
failing over costs a second, not a solve. The agent's solve is not idempotent and is not retried.
"""

from __future__ import annotations

import base64
import copy
import io
import json
import random
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import quote

import httpx
import numpy as np
from httpx_sse import connect_sse
from pydantic import BaseModel, Field, TypeAdapter

from shared.geometry.reconstruction import Reconstruction
from shared.imaging.codecs import encode_image
from shared.wire.schemas import (
    TENANT_HEADER,
    CameraMotionResponse,
    ErrorEvent,
    MotionTarget,
    PointCloudPreview,
    Readiness,
    ReconstructionSummary,
    RouteResponse,
    SceneCreated,
    SceneInfo,
    SolveEvent,
    SolveResponse,
    StageEvent,
)

ImageLike = bytes | np.ndarray | str | Path


class ServiceError(RuntimeError):
    """The service answered with an error status; `message` is its explanation.

    `service` names which service answered ("agent service", ...); `retry_after` is the seconds
    a 429 or 503 asked to wait (its Retry-After header), None when it did not say; `challenged`:
    the answer carried an authentication challenge (WWW-Authenticate), as a refused key's does.
    """

    def __init__(
        self,
        status_code: int,
        message: str,
        url: str,
        service: str = "service",
        retry_after: float | None = None,
        challenged: bool = False,
    ) -> None:
        super().__init__(f"{url} answered {status_code}: {message}")
        self.status_code = status_code
        self.message = message
        self.service = service
        self.retry_after = retry_after
        self.challenged = challenged

    @property
    def refused_key(self) -> bool:
        """The service refused the caller's key: 401, 403 (a key of another tenant), or a 429 that
        throttles failed authentications (it carries the challenge; a rate limit's does not)."""
        return self.status_code in (401, 403) or (self.status_code == 429 and self.challenged)


def _retry_after(response: httpx.Response) -> float | None:
    """Retry-After in seconds (the services send whole seconds; an HTTP date is not used by them)."""
    try:
        return float(response.headers["retry-after"])
    except (KeyError, ValueError):
        return None


class ServiceUnreachable(RuntimeError):
    """Nothing answered at the service URL (not started, wrong URL, or timed out)."""


class ServiceTimeout(ServiceUnreachable):
    """The service accepted the request but did not answer within the timeout."""


def _segment(value: str) -> str:
    """One URL path segment: quoted, so an id can never change the path or add a query."""
    return quote(str(value), safe="")


def image_bytes(image: ImageLike) -> bytes:
    """Encoded image file bytes from a path, raw bytes or an RGB array."""
    if isinstance(image, bytes):
        return image
    if isinstance(image, np.ndarray):
        return encode_image(image, "png")
    return Path(image).expanduser().read_bytes()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.asarray(array, dtype=np.float32), allow_pickle=False)
    return buffer.getvalue()


class RetryPolicy(BaseModel):
    """How a client retries a call that failed on the way (never a timeout: that took its time)."""

    attempts: int = Field(1, ge=1, description="Tries in all; 1 = no retry.")
    backoff_base_s: float = Field(0.25, ge=0, description="First backoff; doubles each retry.")
    backoff_max_s: float = Field(4.0, ge=0, description="Longest backoff between two tries.")
    window_s: float = Field(30.0, gt=0, description="No retry starts later than this after the first try.")

    def delay_s(self, attempt: int, retry_after: float | None) -> float:
        """Before try `attempt + 1`: Retry-After when the server said, else half to all of the backoff."""
        if retry_after is not None:
            return retry_after * (1.0 + 0.1 * random.random())
        ceiling = min(self.backoff_max_s, self.backoff_base_s * 2 ** (attempt - 1))
        return ceiling * (0.5 + 0.5 * random.random())


NO_RETRY = RetryPolicy()
RETRIED_STATUSES = {502, 503}  # a replica or the balancer failing over; the call is idempotent
# Failures on the way where the server cannot have acted on a full request, or acts idempotently.
RETRIED_ERRORS = (httpx.ConnectError, httpx.ReadError, httpx.WriteError, httpx.RemoteProtocolError)


class _ServiceClient:
    service_name = "service"

    def __init__(
        self,
        base_url: str,
        timeout: float = 600.0,
        client: httpx.Client | None = None,
        api_key: str | None = None,
        retry: RetryPolicy = NO_RETRY,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        headers = {"Authorization": f"Bearer {api_key}"} if api_key else {}
        self._http = client or httpx.Client(base_url=self.base_url, timeout=timeout, headers=headers)
        self.retry = retry
        self._headers: dict[str, str] = {}  # sent with every request of this client (its tenant)
        self._deadline: float | None = None  # time.monotonic() by which every call must be over
        self._owns_http = True

    def for_tenant(self, tenant: str):
        """This client on the same connections, each request naming `tenant` (X-PySpatial-Tenant).

        For a service key (`*:key`), which acts for the tenant of the caller it serves: the agent
        calls recon so for each solve. Closing the copy leaves the connections open."""
        view = copy.copy(self)
        view._headers = {**self._headers, TENANT_HEADER: tenant}
        view._owns_http = False
        return view

    def until(self, deadline: float):
        """This client on the same connections, every call over by `deadline` (time.monotonic()):
        no retry starts that would wait past it, and each try's timeout is what is left of it.
        The agent bounds a solve's recon calls so; closing the copy leaves the connections open."""
        view = copy.copy(self)
        view._deadline = deadline if self._deadline is None else min(deadline, self._deadline)
        view._owns_http = False
        return view

    def _request(self, method: str, path: str, **kwargs) -> httpx.Response:
        started = time.monotonic()
        for attempt in range(1, self.retry.attempts + 1):
            try:
                return self._attempt(method, path, **kwargs)
            except (ServiceError, ServiceUnreachable) as error:
                delay = self._retry_delay(error, attempt, started)
                if delay is None:
                    raise
                time.sleep(delay)
        raise AssertionError("unreachable: the last attempt raises")

    def _retry_delay(self, error: Exception, attempt: int, started: float) -> float | None:
        """Seconds to wait before retrying after `error`, or None to give up now."""
        if attempt >= self.retry.attempts or isinstance(error, ServiceTimeout):
            return None
        if isinstance(error, ServiceError):
            if error.status_code not in RETRIED_STATUSES:
                return None
            delay = self.retry.delay_s(attempt, error.retry_after)
        elif isinstance(error.__cause__, RETRIED_ERRORS):
            delay = self.retry.delay_s(attempt, None)
        else:
            return None
        now = time.monotonic()
        if self._deadline is not None and now + delay >= self._deadline:
            return None  # the caller's deadline comes first: a try that could not finish in time
        return delay if now - started + delay <= self.retry.window_s else None

    def _attempt(self, method: str, path: str, **kwargs) -> httpx.Response:
        if self._headers:
            kwargs["headers"] = {**self._headers, **kwargs.get("headers", {})}
        if self._deadline is not None:
            left = self._deadline - time.monotonic()
            if left <= 0:
                raise ServiceTimeout(f"the deadline for calls to the {self.service_name} has passed")
            kwargs["timeout"] = min(left, kwargs.get("timeout") or self._http.timeout.read or left)
        try:
            response = self._http.request(method, self.base_url + path, **kwargs)
        except httpx.TimeoutException as error:
            raise ServiceTimeout(f"the {self.service_name} at {self.base_url} timed out ({error})") from error
        except httpx.TransportError as error:
            raise ServiceUnreachable(
                f"cannot reach the {self.service_name} at {self.base_url}: {error}. "
                f"Is it running? (pyspatial serve)"
            ) from error
        self._raise_for_status(response, method, path)
        return response

    def _raise_for_status(self, response: httpx.Response, method: str, path: str) -> None:
        if response.status_code >= 300:  # redirects are not followed: a path we did not mean
            try:
                detail = response.json().get("detail", response.text)
            except (ValueError, AttributeError):
                detail = response.text
            raise ServiceError(
                response.status_code,
                detail if isinstance(detail, str) else json.dumps(detail),
                f"{method} {path}",
                service=self.service_name,
                retry_after=_retry_after(response),
                challenged="www-authenticate" in response.headers,
            )

    def close(self) -> None:
        if self._owns_http:
            self._http.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class ReconClient(_ServiceClient):
    service_name = "reconstruction service"

    def readyz(self, timeout: float | None = None) -> Readiness:
        """The service's readiness (200 or 503 both carry it); ServiceUnreachable when it is down."""
        try:
            response = self._http.get(self.base_url + "/readyz", timeout=timeout or self._http.timeout)
        except httpx.TimeoutException as error:
            raise ServiceTimeout(
                f"the {self.service_name} at {self.base_url} did not answer /readyz in {timeout} s"
            ) from error
        except httpx.TransportError as error:
            raise ServiceUnreachable(
                f"cannot reach the {self.service_name} at {self.base_url}: {error}"
            ) from error
        try:
            return Readiness.model_validate_json(response.content)
        except ValueError as error:
            raise ServiceError(
                response.status_code,
                f"/readyz answered something else than readiness: {response.text[:200]}",
                "GET /readyz",
            ) from error

    def backbones(self, timeout: float | None = None) -> dict:
        """{"default": name, "available": [names]}"""
        kwargs = {"timeout": timeout} if timeout is not None else {}
        return self._request("GET", "/v1/backbones", **kwargs).json()

    def upload_scene(
        self,
        images: Sequence[ImageLike],
        depths: Sequence[np.ndarray] | None = None,
        extrinsics: np.ndarray | None = None,
        intrinsics: np.ndarray | Sequence[np.ndarray | None] | None = None,
    ) -> SceneCreated:
        """Upload a scene. `intrinsics`: per view a 3x3 in upright-image pixels, or None if unknown."""
        files = [("images", (f"image_{i:03d}", image_bytes(img))) for i, img in enumerate(images)]
        files += [("depths", (f"depth_{i:03d}.npy", _npy(d))) for i, d in enumerate(depths or [])]
        data = {}
        if extrinsics is not None:
            data["extrinsics"] = json.dumps(np.asarray(extrinsics, dtype=float).tolist())
        if intrinsics is not None:
            data["intrinsics"] = json.dumps(
                [None if k is None else np.asarray(k, dtype=float).tolist() for k in intrinsics]
            )
        return SceneCreated.model_validate(self._request("POST", "/v1/scenes", files=files, data=data).json())

    def scene_info(self, scene_id: str) -> SceneInfo:
        return SceneInfo.model_validate(self._request("GET", f"/v1/scenes/{_segment(scene_id)}").json())

    def scene_image(self, scene_id: str, index: int) -> bytes:
        return self._request("GET", f"/v1/scenes/{_segment(scene_id)}/images/{int(index)}").content

    def reconstruct(self, scene_id: str, backbone: str | None = None) -> ReconstructionSummary:
        response = self._request(
            "POST", f"/v1/scenes/{_segment(scene_id)}/reconstruct", json={"backbone": backbone}
        )
        return ReconstructionSummary.model_validate(response.json())

    def reconstruction(self, scene_id: str, backbone: str | None = None) -> Reconstruction:
        params = {"backbone": backbone} if backbone else {}
        response = self._request("GET", f"/v1/scenes/{_segment(scene_id)}/reconstruction", params=params)
        return Reconstruction.from_bytes(response.content)

    @contextmanager
    def export(self, scene_id: str, fmt: str, backbone: str | None = None) -> Iterator[httpx.Response]:
        """The reconstruction as a file (`fmt`: ply, glb or npz), streamed: read `iter_bytes()` inside
        the block. A refusal (404, 422, ...) raises ServiceError before the block runs."""
        path = f"/v1/scenes/{_segment(scene_id)}/reconstruction"
        params = {"format": fmt, **({"backbone": backbone} if backbone else {})}
        try:
            with self._http.stream(
                "GET", self.base_url + path, params=params, headers=self._headers
            ) as response:
                if response.status_code >= 300:
                    response.read()
                    self._raise_for_status(response, "GET", path)
                yield response
        except httpx.TimeoutException as error:
            raise ServiceTimeout(f"the {self.service_name} at {self.base_url} timed out ({error})") from error
        except httpx.TransportError as error:
            raise ServiceUnreachable(
                f"cannot reach the {self.service_name} at {self.base_url}: {error}"
            ) from error

    def ply(self, scene_id: str, backbone: str | None = None) -> bytes:
        params = {"format": "ply", **({"backbone": backbone} if backbone else {})}
        return self._request("GET", f"/v1/scenes/{_segment(scene_id)}/reconstruction", params=params).content

    def render(
        self,
        scene_id: str,
        extrinsic,
        width: int = 512,
        height: int = 512,
        zoom_out: float = 0.5,
        fmt: str = "png",
        backbone: str | None = None,
    ) -> bytes:
        body = {
            "scene_id": scene_id,
            "extrinsic": np.asarray(extrinsic, dtype=float).tolist(),
            "width": width,
            "height": height,
            "zoom_out": zoom_out,
            "format": fmt,
            "backbone": backbone,
        }
        return self._request("POST", "/v1/render", json=body).content

    def points(
        self, scene_id: str, backbone: str | None = None, max_points: int = 30_000
    ) -> PointCloudPreview:
        params = {"max_points": max_points, **({"backbone": backbone} if backbone else {})}
        response = self._request("GET", f"/v1/scenes/{_segment(scene_id)}/points", params=params)
        return PointCloudPreview.model_validate_json(response.content)

    def camera_motion(
        self,
        scene_id: str,
        pairs: Sequence[tuple[int, int]] | None = None,
        backbone: str | None = None,
        target: MotionTarget | None = None,
        from_view: int | None = None,
        to_view: int | None = None,
    ) -> CameraMotionResponse:
        """`pairs` of views (from, to), or `from_view` and `to_view`: views numbered from 1, as the
        sentences count them."""
        body: dict[str, object] = {
            "scene_id": scene_id,
            "pairs": [list(p) for p in pairs] if pairs else None,
            "backbone": backbone,
            "target": target.model_dump(exclude_none=True) if target is not None else None,
        }
        if from_view is not None or to_view is not None:
            body.update(from_view=from_view, to_view=to_view)
        return CameraMotionResponse.model_validate(
            self._request("POST", "/v1/camera-motion", json=body).json()
        )


class AgentClient(_ServiceClient):
    service_name = "agent service"

    def backbones(self) -> dict:
        """{"default": name, "available": [names]} through the agent; a cheap check of the API key."""
        return self._request("GET", "/v1/backbones").json()

    def solve(
        self,
        question: str,
        images: Sequence[ImageLike] | None = None,
        scene_id: str | None = None,
        backbone: str | None = None,
        max_repairs: int | None = None,
    ) -> SolveResponse:
        body = _solve_body(question, images, scene_id, backbone, max_repairs)
        return SolveResponse.model_validate(self._request("POST", "/v1/solve", json=body).json())

    def route(
        self,
        goal: dict,
        images: Sequence[ImageLike] | None = None,
        scene_id: str | None = None,
        start_view: int = 1,
        depths: Sequence[np.ndarray] | None = None,
        extrinsics: np.ndarray | None = None,
        intrinsics: np.ndarray | Sequence[np.ndarray | None] | None = None,
        robot: dict | None = None,
        backbone: str | None = None,
    ) -> RouteResponse:
        """A route plan (POST /v1/route, multipart). `goal`: {"pixel": {"view", "u", "v"}} (1-based
        view), {"point_world": [x, y, z]} or {"point_start_camera": [x, y, z]}."""
        files = [("images", (f"image_{i:03d}", image_bytes(img))) for i, img in enumerate(images or [])]
        files += [("depths", (f"depth_{i:03d}.npy", _npy(d))) for i, d in enumerate(depths or [])]
        data = {"goal": json.dumps(goal), "start_view": str(int(start_view))}
        for name, value in (("scene_id", scene_id), ("backbone", backbone)):
            if value:
                data[name] = value
        if robot is not None:
            data["robot"] = json.dumps(robot)
        if extrinsics is not None:
            data["extrinsics"] = json.dumps(np.asarray(extrinsics, dtype=float).tolist())
        if intrinsics is not None:
            data["intrinsics"] = json.dumps(
                [None if k is None else np.asarray(k, dtype=float).tolist() for k in intrinsics]
            )
        if not files:  # httpx sends multipart only with files: a scene_id alone goes as JSON
            body = {"scene_id": scene_id, "start_view": int(start_view), "goal": goal, "backbone": backbone}
            body.update({"robot": robot} if robot is not None else {})
            return RouteResponse.model_validate(self._request("POST", "/v1/route", json=body).json())
        response = self._request("POST", "/v1/route", files=files, data=data)
        return RouteResponse.model_validate(response.json())

    def solve_with_progress(
        self,
        question: str,
        images: Sequence[ImageLike] | None = None,
        scene_id: str | None = None,
        backbone: str | None = None,
        max_repairs: int | None = None,
        on_stage: Callable[[StageEvent], None] | None = None,
    ) -> SolveResponse:
        """Like `solve`, over the event stream: `on_stage` sees each stage start and end.

        A failed solve raises ServiceError with the status and message /v1/solve would have given.
        """
        body = _solve_body(question, images, scene_id, backbone, max_repairs)
        path = "/v1/solve"
        try:
            with connect_sse(
                self._http, "POST", self.base_url + path, json=body, headers={"Accept": "text/event-stream"}
            ) as source:
                if source.response.status_code >= 400:  # refused before the solve started
                    source.response.read()
                    self._raise_for_status(source.response, "POST", path)
                if source.response.headers.get("content-type", "").startswith("application/json"):
                    # A service that does not stream answers with the plain result: no stages to show.
                    return SolveResponse.model_validate_json(source.response.read())
                for sse in source.iter_sse():
                    event = _SOLVE_EVENT.validate_json(sse.data)
                    if isinstance(event, StageEvent):
                        if on_stage is not None:
                            on_stage(event)
                    elif isinstance(event, ErrorEvent):
                        raise ServiceError(
                            event.status_code, event.detail, f"POST {path}", service=self.service_name
                        )
                    else:
                        return event.result
        except httpx.TimeoutException as error:
            raise ServiceUnreachable(
                f"the {self.service_name} at {self.base_url} timed out ({error})"
            ) from error
        except httpx.TransportError as error:
            raise ServiceUnreachable(
                f"cannot reach the {self.service_name} at {self.base_url}: {error}"
            ) from error
        raise ServiceUnreachable(
            f"the {self.service_name} at {self.base_url} closed the stream without a result"
        )


_SOLVE_EVENT: TypeAdapter = TypeAdapter(SolveEvent)


def _solve_body(question, images, scene_id, backbone, max_repairs) -> dict:
    return {
        "question": question,
        "images": [base64.b64encode(image_bytes(i)).decode("ascii") for i in images] if images else None,
        "scene_id": scene_id,
        "backbone": backbone,
        "max_repairs": max_repairs,
    }
