"""Real TCP servers that misbehave as a broken dependency does: hang after reading a request,
reset the connection, or answer 503 a few times before a real upstream takes over.

They listen on 127.0.0.1 in a thread of the test process; each counts the connections it took.
"""

from __future__ import annotations

import contextlib
import socket
import struct
import threading
from collections.abc import Callable


class MisbehavingServer:
    """Accepts connections and hands each socket to `behave` in its own thread."""

    def __init__(self, behave: Callable[[socket.socket, int], None]) -> None:
        self._behave = behave
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}"
        self.connections = 0
        self.stopped = threading.Event()
        self._lock = threading.Lock()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while not self.stopped.is_set():
            try:
                connection, _ = self._listener.accept()
            except OSError:
                return
            with self._lock:
                self.connections += 1
                number = self.connections
            threading.Thread(target=self._serve, args=(connection, number), daemon=True).start()

    def _serve(self, connection: socket.socket, number: int) -> None:
        with connection:
            try:
                self._behave(connection, number)
            except OSError:
                pass  # the client gave up first

    def close(self) -> None:
        self.stopped.set()
        self._listener.close()

    def __enter__(self) -> MisbehavingServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def read_request_head(connection: socket.socket) -> bytes:
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = connection.recv(65536)
        if not chunk:
            break
        data += chunk
    return data


def hang(stopped: threading.Event) -> Callable[[socket.socket, int], None]:
    """Read the request, then never answer (until the server closes)."""

    def behave(connection: socket.socket, _: int) -> None:
        read_request_head(connection)
        stopped.wait()

    return behave


def reset_connection(connection: socket.socket) -> None:
    """Close with RST (SO_LINGER 0): the client sees "connection reset by peer"."""
    connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))


def reply_503(connection: socket.socket, retry_after: str | None = "0") -> None:
    read_request_head(connection)
    body = b'{"detail": "busy"}'
    head = b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\n"
    if retry_after is not None:
        head += f"retry-after: {retry_after}\r\n".encode()
    head += f"content-length: {len(body)}\r\nconnection: close\r\n\r\n".encode()
    connection.sendall(head + body)


def forward(connection: socket.socket, port: int) -> None:
    """Pipe this connection to a real server on 127.0.0.1:`port`, both ways, until either closes."""
    with socket.create_connection(("127.0.0.1", port)) as upstream:

        def pump(source: socket.socket, target: socket.socket) -> None:
            try:
                while data := source.recv(65536):
                    target.sendall(data)
            except OSError:
                pass
            finally:
                with contextlib.suppress(OSError):
                    target.shutdown(socket.SHUT_WR)

        back = threading.Thread(target=pump, args=(upstream, connection), daemon=True)
        back.start()
        pump(connection, upstream)
        back.join()


def flaky(port: int, failures: list[str]) -> Callable[[socket.socket, int], None]:
    """The n-th connection fails as `failures[n - 1]` says ("reset" or "503"), later ones reach
    the real server on `port`."""

    def behave(connection: socket.socket, number: int) -> None:
        if number > len(failures):
            forward(connection, port)
        elif failures[number - 1] == "reset":
            read_request_head(connection)
            reset_connection(connection)
        else:
            reply_503(connection)

    return behave
