"""Framed messages between the parent and the sandbox process, written for a hostile peer.

A frame is a 4-byte big-endian length, then that many bytes of strict ASCII JSON (non-ASCII text
is escaped by the sender; a byte above 0x7F is an error). Each side reads frames under a hard cap
on the length, announced before any byte of the body is buffered, and checks the nesting depth
in one linear pass before parsing (`nesting_depth`), so a hostile peer costs bounded work. The
parent then checks each child message against its schema (messages.py, pydantic) and its place in
the conversation.

The child's protocol streams are private duplicates of its original stdin/stdout; its fds 0 and 1
are pointed at /dev/null before any program runs, and programs only ever see a captured `print`,
so nothing a program writes can be mistaken for a message.

Child -> parent: {"type": "ready"} once, then {"type": "call", "tool": ..., "arguments": {...}}
                 any number of times, then {"type": "result", ...} once.
Parent -> child: {"type": "job", ...} once, then one {"type": "reply", "ok": true, "value": ...}
                 or {"type": "reply", "ok": false, "error": "..."} per call.
"""

from __future__ import annotations

import json
import os
import re
import selectors
import time
from typing import Any, BinaryIO

import numpy

TOOL_NAMES = (
    "reconstruct",
    "describe_camera_motion",
    "synthesize_novel_view",
    "get_input_image",
    "locate",
    "plan_route",
)


class ProtocolError(RuntimeError):
    """The other side sent something that is not a valid message."""


HEADER_BYTES = 4


def encode_message(message: dict[str, Any]) -> bytes:
    """One frame. NaN stays allowed: unregistered cameras are reported as NaN poses."""
    payload = json.dumps(message, separators=(",", ":"), ensure_ascii=True).encode("ascii")
    return len(payload).to_bytes(HEADER_BYTES, "big") + payload


def frame_length(header: bytes, max_bytes: int) -> int:
    length = int.from_bytes(header, "big")
    if length > max_bytes:
        raise ProtocolError(f"a frame announced {length} bytes; the limit is {max_bytes}")
    return length


MAX_NESTING = 64  # real messages nest a few levels (a 3x4 matrix in a dict in a list)


def decode_message(line: bytes) -> dict[str, Any]:
    """One frame's body; ProtocolError for anything else (bounded work: depth is checked first)."""
    if not line.isascii():
        raise ProtocolError("malformed message: a frame must be ASCII JSON")
    if nesting_depth(line) > MAX_NESTING:
        raise ProtocolError(f"malformed message: nested more than {MAX_NESTING} levels")
    try:
        message = json.loads(line)
    except (ValueError, UnicodeDecodeError, RecursionError) as error:
        raise ProtocolError(f"malformed message: {str(error)[:200]}") from None
    if not isinstance(message, dict) or not isinstance(message.get("type"), str):
        raise ProtocolError("a message must be a JSON object with a 'type'")
    return message


# One JSON string: possessive quantifiers (`++`, `*+`) never give back what they matched, so a
# string that never closes ('"' then N times '\\"') is scanned once, to the end of the frame,
# rather than once from every quote in it (the quadratic cost of a backtracking pattern).
_STRING = re.compile(rb'"(?:[^"\\]++|\\.)*+"?', re.DOTALL)
_STEP = numpy.zeros(256, dtype=numpy.int8)  # +1 for an opening bracket, -1 for a closing one
_STEP[list(b"[{")] = 1
_STEP[list(b"]}")] = -1
_CHUNK_BYTES = 1 << 20  # bounds the numpy temporaries for a large frame


def nesting_depth(line: bytes) -> int:
    """Deepest [ / { nesting outside strings, in time linear in the frame whatever it holds.

    One regex pass cuts the strings out; numpy then sums the brackets left, a chunk at a time, so
    the cost per byte is C code however many brackets there are. For a valid frame this is the
    nesting json.loads will meet; an invalid one fails in json.loads before it goes any deeper.
    """
    codes = numpy.frombuffer(_STRING.sub(b"", line), dtype=numpy.uint8)
    depth = deepest = 0
    for start in range(0, len(codes), _CHUNK_BYTES):
        running = numpy.cumsum(_STEP[codes[start : start + _CHUNK_BYTES]], dtype=numpy.int64) + depth
        deepest = max(deepest, int(running.max()))
        depth = int(running[-1])
    return deepest


def write_message(stream: BinaryIO, message: dict[str, Any]) -> None:
    stream.write(encode_message(message))
    stream.flush()


def read_message(stream: BinaryIO, max_bytes: int) -> dict[str, Any]:
    """The next frame from a blocking stream (the child's side); ProtocolError when it is cut short."""
    length = frame_length(_read_exactly(stream, HEADER_BYTES), max_bytes)
    return decode_message(_read_exactly(stream, length))


def _read_exactly(stream: BinaryIO, size: int) -> bytes:
    data = stream.read(size)
    if data is None or len(data) != size:
        raise ProtocolError("the stream ended inside a frame")
    return data


def send_before(fd: int, message: dict[str, Any], deadline: float) -> None:
    """Write a message to a non-blocking pipe; TimeoutError if the reader stalls past `deadline`.

    The parent never blocks on a child that stopped reading (a full pipe would hang the service).
    """
    data = memoryview(encode_message(message))
    with selectors.DefaultSelector() as selector:
        selector.register(fd, selectors.EVENT_WRITE)
        while data:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not selector.select(timeout=remaining):
                raise TimeoutError
            try:
                written = os.write(fd, data)
            except BlockingIOError:
                continue
            data = data[written:]


class ChildStreams:
    """Parent-side reader of the child's stdout (messages) and stderr (kept tail for diagnostics)."""

    def __init__(self, stdout_fd: int, stderr_fd: int, max_frame_bytes: int, stderr_tail_bytes: int = 16384):
        self.stdout_fd = stdout_fd
        self.stderr_fd = stderr_fd
        self.max_frame_bytes = max_frame_bytes
        self.stderr_tail_bytes = stderr_tail_bytes
        self.buffer = b""
        self.stderr_tail = b""
        self.stdout_open = True
        self.selector = selectors.DefaultSelector()
        self.selector.register(stdout_fd, selectors.EVENT_READ)
        self.selector.register(stderr_fd, selectors.EVENT_READ)

    def close(self) -> None:
        self.selector.close()

    def next_message(self, deadline: float) -> dict[str, Any] | None:
        """The next message, None at end of stream; TimeoutError once `deadline` (monotonic) passes.

        The length is checked as soon as the header is in, so an oversized frame is refused before
        its body is buffered. A stream that ends inside a frame is the end of the stream (the child
        died mid-write, e.g. killed by a limit): the caller reports the death.
        """
        while True:
            if len(self.buffer) >= HEADER_BYTES:
                length = frame_length(self.buffer[:HEADER_BYTES], self.max_frame_bytes)
                end = HEADER_BYTES + length
                if len(self.buffer) >= end:
                    body, self.buffer = self.buffer[HEADER_BYTES:end], self.buffer[end:]
                    return decode_message(body)
            if not self.stdout_open:
                return None
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError
            for key, _ in self.selector.select(timeout=remaining):
                self._read(key.fd)

    def _read(self, fd: int) -> None:
        chunk = os.read(fd, 65536)
        if fd == self.stdout_fd:
            if chunk:
                self.buffer += chunk
            else:
                self.stdout_open = False
                self.selector.unregister(fd)
        elif chunk:
            self.stderr_tail = (self.stderr_tail + chunk)[-self.stderr_tail_bytes :]
        else:
            self.selector.unregister(fd)

    def drain_stderr(self, timeout: float = 0.5) -> str:
        """Whatever is left on stderr (after the child exited), decoded leniently."""
        deadline = time.monotonic() + timeout
        while self.stderr_fd in self.selector.get_map() and time.monotonic() < deadline:
            for key, _ in self.selector.select(timeout=max(deadline - time.monotonic(), 0)):
                self._read(key.fd)
        return self.stderr_tail.decode("utf-8", errors="replace")
