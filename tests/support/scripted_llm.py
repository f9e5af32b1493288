"""A real OpenAI-compatible chat server that replays scripted replies: the tests' language model.

It is the one stand-in the tests use: a FastAPI app under a real uvicorn process, spoken to over HTTP
by the real `openai` package. Each POST /v1/chat/completions takes the next entry of the script
(the queue of the requested model, else the default queue) and records the request, so tests can
assert on prompts. An entry is a text reply, an HTTP error (429 with Retry-After, 500, 400, ...),
a raw body sent verbatim (not JSON, or JSON that is no chat completion: a broken server) and/or a
delay before answering (longer than the client timeout to provoke one; a client that
closes the connection during it is recorded, `client_left`). An entry may
carry the `finish_reason` and `usage` a real server reported (the recorded replies of
tests/support/model_replies.py replay that way), and an error message may contain
"{authorization}", which becomes the request's Authorization header, as servers that echo it do.

Text-only mode (POST /mode {"text_only": true}, or SCRIPTED_LLM_TEXT_ONLY=1 at start) behaves like
llama.cpp with a GGUF chat template: a request whose message content is a list of parts gets
`HTTP 500: can only concatenate str (not "list") to str`, without consuming a scripted reply.

The script is read at start from SCRIPTED_LLM_SCRIPT (JSON) or SCRIPTED_LLM_SCRIPT_FILE (a path),
and replaced over HTTP: POST /script, GET /requests, POST /reset. JSON shape:
{"default": [entry, ...], "models": {"name": [entry, ...]}}, or a bare list for the default queue.
"""

from __future__ import annotations

import asyncio
import json
import os
import time
import uuid
from collections import deque
from pathlib import Path
from typing import Any

import httpx
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, Field, model_validator

from tests.support.processes import ServiceProcess, start_service

DEFAULT_QUEUE = "*"


class ScriptEntry(BaseModel):
    text: str | None = Field(None, description="Assistant message content of a 200 reply.")
    status: int = Field(200, ge=200, le=599)
    error_message: str | None = None
    retry_after: float | None = Field(None, ge=0, description="Retry-After header (seconds) of an error.")
    delay_s: float = Field(0.0, ge=0, description="Wait this long before answering.")
    finish_reason: str = "stop"
    usage: dict[str, int] | None = Field(None, description="Reported token usage; counted words if None.")
    raw_body: str | None = Field(
        None, description="Send this body verbatim (200) instead of a completion: a broken server."
    )
    content_type: str = Field("application/json", description="Content type of a raw body.")

    @model_validator(mode="before")
    @classmethod
    def _plain_text(cls, value: Any) -> Any:
        return {"text": value} if isinstance(value, str) else value  # "hello" is a text reply


class Script(BaseModel):
    default: list[ScriptEntry] = Field(default_factory=list)
    models: dict[str, list[ScriptEntry]] = Field(default_factory=dict)


class ScriptUpdate(BaseModel):
    replies: list[ScriptEntry]
    model: str | None = Field(None, description="Queue of this model; the default queue when None.")
    append: bool = False


class ServerMode(BaseModel):
    text_only: bool = Field(False, description="Refuse list content like llama.cpp's GGUF templates do.")


TEXT_ONLY_ERROR = 'can only concatenate str (not "list") to str'


class RecordedRequest(BaseModel):
    model: str | None
    messages: list[dict[str, Any]]
    response_format: dict[str, Any] | None
    body: dict[str, Any]
    received_at: float
    client_left: bool = Field(False, description="The client closed the connection while we delayed.")


class _State:
    def __init__(self) -> None:
        self.queues: dict[str, deque[ScriptEntry]] = {}
        self.requests: list[RecordedRequest] = []
        self.mode = ServerMode(text_only=os.environ.get("SCRIPTED_LLM_TEXT_ONLY", "") in ("1", "true"))

    def load(self, script: Script) -> None:
        self.queues = {DEFAULT_QUEUE: deque(script.default)}
        for model, entries in script.models.items():
            self.queues[model] = deque(entries)

    def next_entry(self, model: str | None) -> ScriptEntry | None:
        for name in (model, DEFAULT_QUEUE):
            queue = self.queues.get(name) if name is not None else None
            if queue:
                return queue.popleft()
        return None


def _parse_script(raw: str) -> Script:
    data = json.loads(raw)
    if isinstance(data, list):
        data = {"default": data}
    return Script.model_validate(data)


def _initial_script() -> Script:
    if os.environ.get("SCRIPTED_LLM_SCRIPT"):
        return _parse_script(os.environ["SCRIPTED_LLM_SCRIPT"])
    if os.environ.get("SCRIPTED_LLM_SCRIPT_FILE"):
        return _parse_script(Path(os.environ["SCRIPTED_LLM_SCRIPT_FILE"]).read_text())
    return Script()


def _error(status: int, message: str, headers: dict[str, str] | None = None) -> JSONResponse:
    kind = (
        "rate_limit_error" if status == 429 else "server_error" if status >= 500 else "invalid_request_error"
    )
    return JSONResponse({"error": {"message": message, "type": kind, "code": None}}, status, headers=headers)


def _completion(model: str, entry: ScriptEntry, messages: list[dict[str, Any]]) -> dict[str, Any]:
    text = entry.text or ""
    # Whitespace-separated words stand in for tokens: enough for tests that read `usage`.
    prompt_tokens = sum(len(json.dumps(message.get("content", "")).split()) for message in messages)
    completion_tokens = len(text.split())
    if entry.usage is not None:
        prompt_tokens = entry.usage.get("prompt_tokens", prompt_tokens)
        completion_tokens = entry.usage.get("completion_tokens", completion_tokens)
    return {
        "id": f"chatcmpl-{uuid.uuid4().hex[:12]}",
        "object": "chat.completion",
        "created": int(time.time()),
        "model": model,
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": text},
                "finish_reason": entry.finish_reason,
            }
        ],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
        },
    }


def create_app() -> FastAPI:
    app = FastAPI(title="scripted OpenAI-compatible chat server")
    state = _State()
    state.load(_initial_script())

    @app.get("/healthz")
    def healthz() -> dict[str, str]:
        return {"status": "ok"}

    @app.get("/v1/models")
    def models() -> dict[str, Any]:
        names = sorted(name for name in state.queues if name != DEFAULT_QUEUE) or ["scripted"]
        return {
            "object": "list",
            "data": [{"id": name, "object": "model", "owned_by": "tests"} for name in names],
        }

    @app.post("/script")
    def set_script(update: ScriptUpdate) -> dict[str, int]:
        name = update.model or DEFAULT_QUEUE
        queue = state.queues.setdefault(name, deque())
        if not update.append:
            queue.clear()
        queue.extend(update.replies)
        return {"queued": len(queue)}

    @app.post("/mode")
    def set_mode(mode: ServerMode) -> ServerMode:
        state.mode = mode
        return state.mode

    @app.get("/requests")
    def requests() -> list[RecordedRequest]:
        return state.requests

    @app.post("/reset")
    def reset() -> dict[str, str]:
        state.load(Script())
        state.requests.clear()
        state.mode = ServerMode()
        return {"status": "reset"}

    @app.post("/v1/chat/completions")
    async def chat_completions(request: Request) -> JSONResponse:
        try:
            body = await request.json()
        except json.JSONDecodeError:
            return _error(400, "request body is not JSON")
        if not isinstance(body, dict) or not isinstance(body.get("messages"), list):
            return _error(400, "'messages' must be a list")
        model = body.get("model")
        state.requests.append(
            RecordedRequest(
                model=model,
                messages=body["messages"],
                response_format=body.get("response_format"),
                body=body,
                received_at=time.time(),
            )
        )
        if state.mode.text_only and any(
            isinstance(m, dict) and isinstance(m.get("content"), list) for m in body["messages"]
        ):
            return _error(500, TEXT_ONLY_ERROR)
        entry = state.next_entry(model)
        if entry is None:
            return _error(409, f"the scripted LLM has no reply left for model {model!r}")
        if entry.delay_s and await _client_left_during(request, entry.delay_s):
            state.requests[-1].client_left = True  # as a real server stops generating
            return _error(499, "the client closed the connection")
        if entry.status != 200:
            headers = {"Retry-After": f"{entry.retry_after:g}"} if entry.retry_after is not None else None
            message = entry.error_message or f"scripted HTTP {entry.status}"
            message = message.replace("{authorization}", request.headers.get("authorization", ""))
            return _error(entry.status, message, headers)
        if entry.raw_body is not None:
            return Response(entry.raw_body.encode(), media_type=entry.content_type)
        return JSONResponse(_completion(model or "scripted", entry, body["messages"]))

    return app


async def _client_left_during(request: Request, seconds: float) -> bool:
    """Wait `seconds`, watching the connection; True as soon as the client closes it."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if await request.is_disconnected():
            return True
        await asyncio.sleep(min(0.05, max(0.0, deadline - time.monotonic())))
    return False


class ScriptedLLM:
    """A running scripted server and the calls tests make to it."""

    def __init__(self, service: ServiceProcess) -> None:
        self.service = service

    @property
    def base_url(self) -> str:
        """The OpenAI API root to give a client."""
        return self.service.url + "/v1"

    def script(
        self, replies: list[dict[str, Any] | str], model: str | None = None, append: bool = False
    ) -> None:
        """Queue replies; a plain string is a text reply."""
        body = {"replies": replies, "model": model, "append": append}
        httpx.post(self.service.url + "/script", json=body, timeout=5.0).raise_for_status()

    def requests(self) -> list[dict[str, Any]]:
        response = httpx.get(self.service.url + "/requests", timeout=5.0)
        response.raise_for_status()
        return response.json()

    def reset(self) -> None:
        """Empty queues, forget requests, and leave text-only mode."""
        httpx.post(self.service.url + "/reset", timeout=5.0).raise_for_status()

    def text_only(self, enabled: bool = True) -> None:
        """Refuse list content from now on, as a llama.cpp server with a GGUF template does."""
        httpx.post(self.service.url + "/mode", json={"text_only": enabled}, timeout=5.0).raise_for_status()

    def stop(self) -> None:
        self.service.stop()


def start_scripted_llm(script: dict[str, Any] | list[dict[str, Any]] | None = None) -> ScriptedLLM:
    """Start the server as a real uvicorn process on a free port; `script` is loaded at start."""
    env = {"SCRIPTED_LLM_SCRIPT": json.dumps(script)} if script is not None else {}
    return ScriptedLLM(start_service("tests.support.scripted_llm:create_app", env=env))
