"""The schema of what the sandbox worker may say, checked by the parent (pydantic, strict).

A worker is treated as a hostile peer: each frame it sends is one of these models, with no extra
fields and no type coercion, and in its place in the conversation (one `ready`, then calls, then
one `result`). Anything else ends the run with a ProtocolError whose message says what was wrong.
Parent side only: the worker never imports pydantic (the jail mounts numpy, PIL and pyseccomp).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from services.agent.sandbox.protocol import TOOL_NAMES, ProtocolError

FAILURE_KINDS = ("rejected", "memory", "exception", "output", "crash")
MAX_ERROR_CHARS = 8000  # the worker bounds its own messages to about a quarter of this
MAX_IMAGES = 64  # the run's own, smaller limit is checked when the result is collected


class _Message(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class Ready(_Message):
    type: Literal["ready"]


class Call(_Message):
    type: Literal["call"]
    tool: Literal[TOOL_NAMES]  # type: ignore[valid-type]
    arguments: dict[str, Any]


class Result(_Message):
    type: Literal["result"]
    ok: bool
    text: str | None = None
    images: list[str] = Field(default_factory=list, max_length=MAX_IMAGES)
    stdout: str = ""
    error: str | None = Field(default=None, max_length=MAX_ERROR_CHARS)
    kind: Literal[FAILURE_KINDS] | None = None  # type: ignore[valid-type]


ChildMessage = Annotated[Ready | Call | Result, Field(discriminator="type")]
_ADAPTER: TypeAdapter[Ready | Call | Result] = TypeAdapter(ChildMessage)
_TYPES = {"ready": Ready, "call": Call, "result": Result}


def child_message(message: dict[str, Any], expected: tuple[type[_Message], ...]) -> Ready | Call | Result:
    """`message` as its model, if it is one of `expected` here; ProtocolError saying why not."""
    kind = message.get("type")
    if kind not in _TYPES:
        raise ProtocolError(f"unexpected message type {str(kind)[:40]!r}")
    if _TYPES[kind] not in expected:
        wanted = " or ".join(model.__name__.lower() for model in expected)
        raise ProtocolError(f"a {kind!r} message out of order (expected {wanted})")
    try:
        return _ADAPTER.validate_python(message)
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first["loc"][1:]) or "message"
        raise ProtocolError(f"invalid {kind} message: {where}: {first['msg']}") from None
