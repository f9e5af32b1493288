"""Keys out of logs and error bodies, in every encoding a client or a server might use.

A key can travel as a bearer token, inside HTTP Basic credentials (base64 of `user:key`), in a
query string (`?api_key=...`, percent-encoded or not), or be echoed back by a model server. `scrub`
replaces the known secrets in each of those forms and anything shaped like a credential;
`install_log_scrubbing` applies it to every log record the process makes (uvicorn's access log
included), so a key a client put in a URL never reaches a log file.
"""

from __future__ import annotations

import base64
import binascii
import logging
import re
import threading
from urllib.parse import quote, quote_plus

REDACTED = "[redacted]"

# Credentials by shape: header echoes, Basic and bearer tokens, query parameters, provider keys.
_SECRET_PATTERNS = (
    re.compile(r"(?i)(authorization[\"']?\s*[:=]\s*[\"']?)(?:bearer|basic|token)?\s*[^\s\"',;}]+"),
    re.compile(r"(?i)\b(bearer\s+)[A-Za-z0-9._~+/=-]{6,}"),
    re.compile(r"(?i)\b(basic\s+)[A-Za-z0-9+/=_-]{4,}"),
    re.compile(
        r"(?i)((?:api[_-]?key|x-api-key|access[_-]?token|secret|password)[\"']?\s*[:=]\s*[\"']?)[^\s\"',;&}]+"
    ),
    re.compile(r"(?i)([?&](?:key|token|auth|apikey|access_token)=)[^&\s\"']+"),
    re.compile(r"\b(?:sk|rk|pk)-[A-Za-z0-9_-]{12,}"),
    re.compile(r"\bhf_[A-Za-z0-9]{20,}"),
)
_BASE64_TOKEN = re.compile(r"[A-Za-z0-9+/_-]{8,}={0,2}")


def encoded_forms(secret: str) -> set[str]:
    """The secret as it may appear in text: plain, percent-encoded, base64 (standard, URL-safe)."""
    forms = {secret, quote(secret, safe=""), quote_plus(secret)}
    raw = secret.encode()
    for encode in (base64.b64encode, base64.urlsafe_b64encode):
        forms |= {encode(raw).decode(), encode(raw).decode().rstrip("=")}
    return {form for form in forms if len(form) >= 4}


def _hides_a_secret(token: str, secrets: tuple[str, ...]) -> bool:
    """A base64 token whose decoding holds a secret (Basic `user:key`, a key encoded at an offset)."""
    padded = token + "=" * (-len(token) % 4)
    for decode in (base64.b64decode, base64.urlsafe_b64decode):
        try:
            text = decode(padded).decode("utf-8", "ignore")
        except (binascii.Error, ValueError):
            continue
        if any(secret in text for secret in secrets):
            return True
    return False


def scrub(text: str, secrets: tuple[str, ...] | list[str] = ()) -> str:
    """`text` with the secrets (in every encoded form) and credential-shaped strings replaced."""
    secrets = tuple(secret for secret in secrets if secret and len(secret) >= 4)
    for secret in secrets:
        for form in sorted(encoded_forms(secret), key=len, reverse=True):
            text = text.replace(form, REDACTED)
    if secrets:
        text = _BASE64_TOKEN.sub(
            lambda match: REDACTED if _hides_a_secret(match.group(0), secrets) else match.group(0), text
        )
    for pattern in _SECRET_PATTERNS:
        text = pattern.sub(lambda match: (match.group(1) if match.groups() else "") + REDACTED, text)
    return text


_lock = threading.Lock()
_log_secrets: set[str] = set()
_installed = False


def install_log_scrubbing(secrets: list[str]) -> None:
    """Scrub every log record of this process from now on (message and string arguments)."""
    global _installed
    with _lock:
        _log_secrets.update(secret for secret in secrets if secret)
        if _installed:
            return
        _installed = True
        make_record = logging.getLogRecordFactory()

    def scrubbed_record(*args, **kwargs) -> logging.LogRecord:
        record = make_record(*args, **kwargs)
        known = tuple(_log_secrets)
        if isinstance(record.msg, str):
            record.msg = scrub(record.msg, known)
        if isinstance(record.args, tuple):
            record.args = tuple(scrub(arg, known) if isinstance(arg, str) else arg for arg in record.args)
        return record

    logging.setLogRecordFactory(scrubbed_record)
