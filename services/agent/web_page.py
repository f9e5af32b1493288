"""The web page as it is served: its HTML with Subresource Integrity, and the headers of every response.

Built once when the app starts (`build_page`), from the files in `services/agent/web/`:
- every `<script src="/web/...">` and `<link href="/web/...">` tag of `index.html` gets
  `integrity="sha384-..."` of the file it names, and the inline import map gets an `integrity`
  section for every JavaScript module under `/web/` (a module imported by another carries no
  attribute of its own; the browser checks it against the import map);
- the import map is the page's one inline `<script>` and holds no code; the Content-Security-Policy
  allows exactly its text by its sha256, so no inline script runs.

`SecurityHeaders` adds to every response `X-Content-Type-Options: nosniff`, `Referrer-Policy:
no-referrer` and `X-Frame-Options: DENY`, and to the page and its static files the policy and
their cache lifetime: a year (immutable) for the versioned vendor folders (`vendor/<name>-<version>/`,
a new version is a new URL), revalidation (`no-cache`, with ETag) for the page's own files.
The API docs (`/docs`, `/redoc`) load Swagger UI from a CDN with inline scripts, so they keep no CSP.

Computed here, at start-up, rather than committed into index.html: the page's own modules change
with every edit, and a hash pasted by hand goes stale silently, while one made from the files that
are served cannot.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path

from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

WEB_DIR = Path(__file__).resolve().parent / "web"
WEB_PREFIX = "/web/"
VENDOR_PREFIX = "/web/vendor/"
VERSIONED_VENDOR = re.compile(r"^/web/vendor/[a-z][a-z0-9_.]*-\d+(?:\.\d+)+/")
IMMUTABLE = "public, max-age=31536000, immutable"
REVALIDATE = "no-cache"

_TAG = re.compile(r"<(?:script|link)\b[^>]*?\b(?:src|href)=\"(/web/[^\"]+)\"[^>]*>")
_IMPORT_MAP = re.compile(r"(<script type=\"importmap\">)(.*?)(</script>)", re.DOTALL)

# Everything the page loads comes from its own origin; images also from data: (clue renders) and
# blob: (the photos chosen in the browser). Nothing may frame it, and no plugin or <base> applies.
_POLICY = (
    "default-src 'none'",
    "script-src 'self' {import_map}",
    "style-src 'self'",
    "img-src 'self' data: blob:",
    "connect-src 'self'",
    "font-src 'self'",
    "base-uri 'none'",
    "form-action 'self'",
    "frame-ancestors 'none'",
    "object-src 'none'",
)


def integrity(data: bytes) -> str:
    """The Subresource Integrity value of `data` (sha384, as the SRI spec recommends)."""
    return "sha384-" + base64.b64encode(hashlib.sha384(data).digest()).decode("ascii")


def csp_hash(text: str) -> str:
    """The CSP source expression that allows exactly this inline script text."""
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode("ascii") + "'"


@dataclass(frozen=True)
class WebPage:
    html: bytes
    content_security_policy: str


def build_page(web_dir: Path = WEB_DIR) -> WebPage:
    """index.html with integrity on every tag and in the import map, and the CSP that allows it."""
    html = (web_dir / "index.html").read_text()
    html = _TAG.sub(lambda match: _with_integrity(match.group(0), web_dir, match.group(1)), html)
    found = _IMPORT_MAP.search(html)
    if found is None:
        raise RuntimeError("index.html has no import map")
    import_map = _import_map_with_integrity(found.group(2), web_dir)
    html = html[: found.start(2)] + import_map + html[found.end(2) :]
    policy = "; ".join(_POLICY).format(import_map=csp_hash(import_map))
    return WebPage(html=html.encode(), content_security_policy=policy)


def _file_of(web_dir: Path, url: str) -> Path:
    path = (web_dir / url.removeprefix(WEB_PREFIX)).resolve()
    if web_dir.resolve() not in path.parents or not path.is_file():
        raise RuntimeError(f"index.html names {url}, which is not a file of {web_dir}")
    return path


def _with_integrity(tag: str, web_dir: Path, url: str) -> str:
    if " integrity=" in tag:
        raise RuntimeError(f"index.html: {url} has an integrity attribute by hand; it is computed")
    value = integrity(_file_of(web_dir, url).read_bytes())
    return tag[:-1].rstrip("/").rstrip() + f' integrity="{value}">'


def _import_map_with_integrity(text: str, web_dir: Path) -> str:
    mapping = json.loads(text)
    modules = sorted(path for path in web_dir.rglob("*.js") if path.is_file())
    mapping["integrity"] = {
        WEB_PREFIX + path.relative_to(web_dir).as_posix(): integrity(path.read_bytes()) for path in modules
    }
    return "\n" + json.dumps(mapping, indent=2) + "\n"


def cache_control(path: str) -> str | None:
    """The cache lifetime of a page file: a year for versioned vendor folders, else revalidate."""
    if VERSIONED_VENDOR.match(path):
        return IMMUTABLE
    if path == "/" or path.startswith(WEB_PREFIX):
        return REVALIDATE
    return None


class SecurityHeaders:
    """Pure ASGI middleware (it must not buffer the solve's event stream): the headers above."""

    def __init__(self, app: ASGIApp, page_policy: str) -> None:
        self.app = app
        self.page_policy = page_policy

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        path = scope["path"]
        on_page = path == "/" or path.startswith(WEB_PREFIX)

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                headers["X-Content-Type-Options"] = "nosniff"
                headers["Referrer-Policy"] = "no-referrer"
                headers["X-Frame-Options"] = "DENY"
                if on_page:
                    headers["Content-Security-Policy"] = self.page_policy
                    lifetime = cache_control(path)
                    if lifetime and message["status"] < 400:
                        headers["Cache-Control"] = lifetime
            await send(message)

        await self.app(scope, receive, send_with_headers)


__all__ = ["SecurityHeaders", "WebPage", "build_page", "cache_control", "csp_hash", "integrity"]
