"""JSON-lines messages between the parent and the sandbox process.

The child's protocol streams are private duplicates of its original stdin/stdout; its fds 0 and 1
are pointed at /dev/null before any program runs, and programs only ever see a captured `print`,
so nothing a program writes can be mistaken for a message.

Child -> parent: {"type": "ready"}, {"type": "call", "tool": ..., "arguments": {...}},
                 {"type": "result", ...}.
Parent -> child: {"type": "job", ...}, {"type": "reply", "ok": true, "value": ...} or
                 {"type": "reply", "ok": false, "error": "..."}.
"""

from __future__ import annotations

import json
import os
import re
import selectors
import time
from typing import Any, BinaryIO

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


def encode_message(message: dict[str, Any]) -> bytes:
    # NaN stays allowed: unregistered cameras are reported as NaN poses.
    return json.dumps(message, separators=(",", ":")).encode("utf-8") + b"\n"


MAX_NESTING = 64  # real messages nest a few levels (a 3x4 matrix in a dict in a list)


def decode_message(line: bytes) -> dict[str, Any]:
    """One message; ProtocolError for anything else (bounded work: depth is checked before parsing)."""
    if _nesting_depth(line) > MAX_NESTING:
        raise ProtocolError(f"malformed message: nested more than {MAX_NESTING} levels")
    try:
        message = json.loads(line)
    except (ValueError, UnicodeDecodeError, RecursionError) as error:
        raise ProtocolError(f"malformed message: {str(error)[:200]}") from None
    if not isinstance(message, dict) or not isinstance(message.get("type"), str):
        raise ProtocolError("a message must be a JSON object with a 'type'")
    return message


_BRACKETS = re.compile(rb'[\[\]{}]|"(?:[^"\\]|\\.)*"')


def _nesting_depth(line: bytes) -> int:
    """Deepest [ / { nesting outside strings, in one linear pass."""
    depth = deepest = 0
    for match in _BRACKETS.finditer(line):
        token = match.group()
        if token in (b"[", b"{"):
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_NESTING:
                break
        elif token in (b"]", b"}"):
            depth -= 1
    return deepest


def write_message(stream: BinaryIO, message: dict[str, Any]) -> None:
    stream.write(encode_message(message))
    stream.flush()


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

    def __init__(self, stdout_fd: int, stderr_fd: int, max_line_bytes: int, stderr_tail_bytes: int = 4096):
        self.stdout_fd = stdout_fd
        self.stderr_fd = stderr_fd
        self.max_line_bytes = max_line_bytes
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
        """The next message, None at end of stream; TimeoutError once `deadline` (monotonic) passes."""
        while True:
            newline = self.buffer.find(b"\n")
            if newline >= 0:
                line, self.buffer = self.buffer[:newline], self.buffer[newline + 1 :]
                return decode_message(line)
            if len(self.buffer) > self.max_line_bytes:
                raise ProtocolError(f"a message from the sandbox exceeded {self.max_line_bytes} bytes")
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
