"""A local stand-in of the Hugging Face hub's file API, for the weights tests.

It answers what huggingface_hub's `hf_hub_download` asks on resolve, with the headers it reads:
HEAD and GET `/{repo_id}/resolve/{revision}/{filename}` with `X-Repo-Commit`, `ETag` and
`X-Linked-Etag` (the file's sha256, as the hub gives for LFS files), `X-Linked-Size` and
`Content-Length`; GET honours `Range: bytes=N-` (206 + `Content-Range`). Unknown repositories,
revisions and files are 404s with the hub's `X-Error-Code`. `drop_after` makes the next GET stop
after that many bytes of the body and close the connection, as a dropped download does.
"""

from __future__ import annotations

import hashlib
import re
import threading
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

# Model files resolve at /{repo}/..., dataset files at /datasets/{repo}/... (eval mmsi --fetch).
RESOLVE = re.compile(r"^/(?:datasets/)?(?P<repo>[^/]+/[^/]+)/resolve/(?P<revision>[^/]+)/(?P<filename>.+)$")


@dataclass
class HostedFile:
    data: bytes
    sha256: str = ""

    def __post_init__(self) -> None:
        self.sha256 = hashlib.sha256(self.data).hexdigest()


@dataclass
class HubStandIn:
    files: dict[tuple[str, str], HostedFile] = field(default_factory=dict)  # (repo_id, filename) -> file
    requests: list[tuple[str, str, str | None]] = field(default_factory=list)  # method, path, Range
    drop_after: int | None = None

    def host(self, repo_id: str, filename: str, path: Path) -> HostedFile:
        hosted = HostedFile(path.read_bytes())
        self.files[(repo_id, filename)] = hosted
        return hosted

    @staticmethod
    def commit(repo_id: str) -> str:
        return hashlib.sha1(repo_id.encode()).hexdigest()

    def start(self) -> str:
        hub = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args: object) -> None:  # keep test output clean
                pass

            def do_HEAD(self) -> None:  # noqa: N802 - http.server's naming
                hub.answer(self, body=False)

            def do_GET(self) -> None:  # noqa: N802
                hub.answer(self, body=True)

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        return f"http://127.0.0.1:{self.server.server_address[1]}"

    def stop(self) -> None:
        self.server.shutdown()
        self.server.server_close()

    def _not_found(self, handler: BaseHTTPRequestHandler, code: str, commit: str | None) -> None:
        handler.send_response(404)
        handler.send_header("X-Error-Code", code)
        handler.send_header("X-Error-Message", f"{code} (stand-in hub)")
        if commit:
            handler.send_header("X-Repo-Commit", commit)
        handler.send_header("Content-Length", "0")
        handler.end_headers()

    def answer(self, handler: BaseHTTPRequestHandler, body: bool) -> None:
        self.requests.append((handler.command, handler.path, handler.headers.get("Range")))
        match = RESOLVE.match(handler.path.split("?")[0])
        if match is None or not any(repo == match["repo"] for repo, _ in self.files):
            self._not_found(handler, "RepoNotFound", None)
            return
        commit = self.commit(match["repo"])
        if match["revision"] not in ("main", commit):
            self._not_found(handler, "RevisionNotFound", None)
            return
        hosted = self.files.get((match["repo"], match["filename"]))
        if hosted is None:
            self._not_found(handler, "EntryNotFound", commit)
            return
        start = 0
        ranged = re.match(r"bytes=(\d+)-$", handler.headers.get("Range") or "")
        if body and ranged:
            start = int(ranged[1])
        handler.send_response(206 if start else 200)
        for name, value in (
            ("X-Repo-Commit", commit),
            ("ETag", f'"{hosted.sha256}"'),
            ("X-Linked-Etag", f'"{hosted.sha256}"'),
            ("X-Linked-Size", str(len(hosted.data))),
            ("Accept-Ranges", "bytes"),
            ("Content-Length", str(len(hosted.data) - start)),
        ):
            handler.send_header(name, value)
        if start:
            handler.send_header("Content-Range", f"bytes {start}-{len(hosted.data) - 1}/{len(hosted.data)}")
        handler.end_headers()
        if not body:
            return
        payload = hosted.data[start:]
        if self.drop_after is not None:
            payload, self.drop_after = payload[: self.drop_after], None
            handler.wfile.write(payload)
            handler.wfile.flush()
            handler.close_connection = True
            handler.connection.shutdown(2)
            return
        handler.wfile.write(payload)
