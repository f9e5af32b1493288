"""A chat client for any OpenAI-compatible endpoint (OpenAI, vLLM, Ollama, llama.cpp server).

The `openai` package does the HTTP; retries are ours (the package's own are switched off) so that
every attempt is counted, Retry-After is honoured, and the final error names the endpoint, the
model and the reason. Retried: 408, 429, 5xx that look transient, timeouts and connection failures.
Not retried: other 4xx, and 5xx whose message says the request itself cannot work (a server that
cannot take content parts, a Python exception text, an exceeded context) — they fail again.

Endpoints as they are: a text-only model (`text_only=True`) gets every message as one plain string
and no images; a server that answers list content with an error saying so (llama.cpp's GGUF chat
templates: `can only concatenate str (not "list") to str`) is reported as `ContentPartsRefused`,
which names the setting to turn on. A rejected key (401/403) is `ModelAuthError`. Every error text
is scrubbed of the key and of anything that looks like a credential before it leaves this module
(servers echo the Authorization header back in their errors). A 200 whose body is not JSON or not
shaped like a chat completion is `ModelReplyMalformed`, naming the endpoint and what was wrong.
"""

from __future__ import annotations

import base64
import email.utils
import random
import re
import time
from collections.abc import Callable
from typing import Any

import openai
from pydantic import BaseModel, Field, SecretStr

from services.agent import cancellation
from shared.wire.scrubbing import scrub

# Local servers (vLLM, Ollama, llama.cpp) ignore the key, but the openai package insists on one.
_PLACEHOLDER_KEY = "not-needed"


class LLMError(RuntimeError):
    """Base class of chat model failures."""


class ModelUnavailable(LLMError):  # noqa: N818 (the name reads better than ModelUnavailableError)
    """The endpoint could not be reached or kept failing (429, 5xx, timeouts) through every retry."""


class ModelError(LLMError):
    """The endpoint refused the request (4xx other than 429) or replied with something unusable."""


class ModelConfigurationError(ModelError):
    """The model cannot work as configured (key, content format): the operator must fix a setting.

    Unlike a transient failure this is never hidden behind a fallback: the client sees it.
    """


class ModelAuthError(ModelConfigurationError):
    """The endpoint rejected the API key (HTTP 401 or 403)."""


class ModelNotFound(ModelConfigurationError):
    """The endpoint does not serve the configured model, or the base URL is not an API root (404)."""


class ContentPartsRefused(ModelConfigurationError):
    """The server cannot take list content (text + image parts): the model must be set text-only."""


class ModelReplyMalformed(ModelConfigurationError):
    """A 200 whose body is not JSON, or JSON that is not a chat completion: not an OpenAI-compatible
    endpoint (a proxy's HTML page, a wrong path), so the solve ends as a 502 that says so."""


class ChatModelConfig(BaseModel):
    base_url: str = Field(description="OpenAI-compatible API root, e.g. http://127.0.0.1:8000/v1")
    model: str
    api_key: SecretStr | None = None
    timeout_s: float = Field(60.0, gt=0)
    max_retries: int = Field(3, ge=0, description="Extra attempts after the first one.")
    temperature: float = Field(0.0, ge=0.0, le=2.0)
    max_tokens: int | None = Field(None, ge=1, description="Longest reply; None leaves it to the server.")
    text_only: bool = Field(
        False, description="Send every message as one plain string and no images (text-only models)."
    )
    text_only_hint: str = Field(
        "configure this model as text-only",
        description="What the operator should do when the server refuses content parts.",
    )
    key_setting: str = Field(
        "the model's API key setting", description="Where the operator sets the key, for a rejected one."
    )
    backoff_base_s: float = Field(0.5, ge=0.0, description="First backoff; doubles each retry.")
    backoff_max_s: float = Field(20.0, ge=0.0, description="Longest backoff between two attempts.")
    max_retry_after_s: float = Field(60.0, ge=0.0, description="Longest Retry-After we are willing to wait.")

    @property
    def label(self) -> str:
        return f"model {self.model!r} at {self.base_url}"


class TokenUsage(BaseModel):
    prompt_tokens: int | None = None
    completion_tokens: int | None = None
    total_tokens: int | None = None


class ChatReply(BaseModel):
    text: str
    model: str
    usage: TokenUsage | None = None
    finish_reason: str | None = Field(None, description="'length' when max_tokens cut the reply.")
    latency_ms: float = Field(description="Wall time of the whole call, retries and waits included.")
    attempts: int


def text_part(text: str) -> dict[str, Any]:
    return {"type": "text", "text": text}


def image_part(png_bytes: bytes, mime_type: str = "image/png") -> dict[str, Any]:
    """An image content part carrying the bytes inline as a base64 data URL."""
    encoded = base64.b64encode(png_bytes).decode("ascii")
    return {"type": "image_url", "image_url": {"url": f"data:{mime_type};base64,{encoded}"}}


# Where a server says it cannot take a list of content parts (llama.cpp GGUF templates, vLLM and
# TGI text-only chat templates, OpenAI-style validators).
_CONTENT_PARTS_REFUSED = re.compile(
    r"can only concatenate str \(not \"list\"\)|"
    r"(?:content|message)s?\b[^.\n]{0,40}\bmust be (?:a )?str|"
    r"expected (?:a )?str(?:ing)?[^.\n]{0,20}(?:got|not) (?:a )?(?:list|array|sequence)|"
    r"invalid type: sequence, expected a string|"
    r"(?:image|multimodal|vision)[^.\n]{0,40}(?:not supported|unsupported|not enabled)|"
    r"does not support (?:image|multimodal|vision)|"
    r"unsupported content (?:part|type)",
    re.IGNORECASE,
)
# 5xx texts that say the request itself cannot work: the same request fails the same way again.
_DETERMINISTIC_SERVER_ERROR = re.compile(
    r"\b(?:TypeError|KeyError|ValueError|AttributeError|IndexError|NotImplementedError)\b|"
    r"context (?:length|window|size)|maximum context|too many tokens|exceeds? the (?:model|maximum)|"
    r"not implemented|unsupported|not supported|invalid (?:request|argument|parameter)|"
    r"chat template|jinja",
    re.IGNORECASE,
)
_TRANSIENT_STATUSES = {408, 429, 502, 503, 504}


def scrub_secrets(text: str, secrets: list[str] | tuple[str, ...] = ()) -> str:
    """`text` with the given secret values (in every encoding) and credential-shaped strings replaced."""
    return scrub(text, secrets)


def plain_text_content(content: Any) -> str:
    """One string from a message's content: text parts joined, image parts named, never sent."""
    if isinstance(content, str):
        return content
    pieces = []
    for part in content or []:
        if isinstance(part, dict) and part.get("type") == "text":
            pieces.append(str(part.get("text", "")))
        elif isinstance(part, dict):
            pieces.append("[an image was left out: this model reads text only]")
        else:
            pieces.append(str(part))
    return "\n".join(pieces)


def as_text_only(messages: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The messages with every content a plain string (what text-only chat templates accept)."""
    return [{**message, "content": plain_text_content(message.get("content"))} for message in messages]


def _has_content_parts(messages: list[dict[str, Any]]) -> bool:
    return any(isinstance(message.get("content"), list) for message in messages)


def _retry_after_s(error: openai.APIStatusError) -> float | None:
    """Seconds the server asked us to wait: retry-after-ms, Retry-After seconds or an HTTP date."""
    headers = error.response.headers
    milliseconds = headers.get("retry-after-ms")
    if milliseconds:
        try:
            return max(0.0, float(milliseconds) / 1000.0)
        except ValueError:
            pass
    value = headers.get("retry-after")
    if not value:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        moment = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    return max(0.0, moment.timestamp() - time.time())


def _status_detail(error: openai.APIStatusError) -> str:
    """HTTP status and the server's own message (the package puts the `error` object in `body`)."""
    body = error.body
    message = body.get("message") if isinstance(body, dict) else None
    return f"HTTP {error.status_code}: {message or error.message}"


def completion_shape_problem(body: Any) -> str | None:
    """What is wrong with a chat completion body, in the fields this client reads; None if fine."""
    if not isinstance(body, dict):
        return f"the body is a JSON {type(body).__name__}, not an object"
    choices = body.get("choices")
    if not isinstance(choices, list):
        return "'choices' is missing or not a list"
    if not choices:
        return None  # an empty list is the model's answer: `_reply` says "returned no choices"
    first = choices[0]
    message = first.get("message") if isinstance(first, dict) else None
    if not isinstance(message, dict):
        return "'choices[0].message' is missing or not an object"
    if not isinstance(message.get("content"), (str, type(None))):
        return "'choices[0].message.content' is not a string"
    usage = body.get("usage")
    if usage is not None and not isinstance(usage, dict):
        return "'usage' is not an object"
    return None


class ChatClient:
    """Chat completions with counted retries; one instance per configured model."""

    def __init__(self, config: ChatModelConfig, sleep: Callable[[float], None] = time.sleep) -> None:
        self.config = config
        self._sleep = sleep
        api_key = config.api_key.get_secret_value() if config.api_key else _PLACEHOLDER_KEY
        self._secrets = (api_key,) if config.api_key else ()
        self._client = openai.OpenAI(
            base_url=config.base_url,
            api_key=api_key,
            timeout=config.timeout_s,
            max_retries=0,
            # one connection per call, so a cancelled solve can abandon it (services/agent/cancellation.py)
            http_client=cancellation.abortable_http_client(config.timeout_s),
        )

    def close(self) -> None:
        self._client.close()

    def __enter__(self) -> ChatClient:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _backoff_s(self, attempt: int) -> float:
        """Exponential backoff with jitter: between half and all of base * 2^(attempt-1), capped."""
        ceiling = min(self.config.backoff_max_s, self.config.backoff_base_s * 2 ** (attempt - 1))
        return ceiling * (0.5 + 0.5 * random.random())

    def scrub(self, text: str) -> str:
        """`text` without this client's key or anything shaped like a credential."""
        return scrub_secrets(text, self._secrets)

    def complete(
        self,
        messages: list[dict[str, Any]],
        response_format: dict[str, Any] | None = None,
        temperature: float | None = None,
    ) -> ChatReply:
        """One chat completion. Raises ModelUnavailable or ModelError (see the module docstring).

        `temperature` overrides the configured one for this call (repairs raise it).
        """
        config = self.config
        if config.text_only:
            messages = as_text_only(messages)
        options: dict[str, Any] = {"temperature": config.temperature if temperature is None else temperature}
        if config.max_tokens is not None:
            options["max_tokens"] = config.max_tokens
        if response_format is not None:
            options["response_format"] = response_format
        started = time.perf_counter()
        total_attempts = config.max_retries + 1
        last_reason = ""
        stop = cancellation.current()
        for attempt in range(1, total_attempts + 1):
            wait_s: float | None = None
            if stop is not None:
                stop.check()
            try:
                raw = self._client.chat.completions.with_raw_response.create(
                    model=config.model, messages=messages, **options
                )
            except openai.APITimeoutError:
                last_reason = f"timed out after {config.timeout_s:g}s"
            except openai.APIConnectionError as error:
                if stop is not None:
                    stop.check()  # the solve was cancelled: its socket was shut down on purpose
                last_reason = self.scrub(f"connection failed ({error.__cause__ or error.message})")
            except openai.APIStatusError as error:
                last_reason = self.scrub(_status_detail(error))
                self._raise_if_final(error, last_reason, _has_content_parts(messages))
                wait_s = _retry_after_s(error)
                if wait_s is not None and wait_s > config.max_retry_after_s:
                    raise ModelUnavailable(
                        f"{config.label} asked us to retry after {wait_s:.0f}s, more than the "
                        f"{config.max_retry_after_s:g}s we wait: {last_reason}"
                    ) from None
            else:
                return self._reply(self._completion(raw), started, attempt)
            if attempt == total_attempts:
                break
            # A server's Retry-After wins; a little jitter keeps clients from returning in lockstep.
            delay = wait_s * (1.0 + 0.1 * random.random()) if wait_s is not None else self._backoff_s(attempt)
            if stop is None:
                self._sleep(delay)
            elif stop.wait(delay):
                stop.check()
        raise ModelUnavailable(f"{config.label} failed after {total_attempts} attempt(s): {last_reason}")

    def _raise_if_final(self, error: openai.APIStatusError, reason: str, sent_parts: bool) -> None:
        """Raise the right ModelError when retrying cannot help; return for transient failures.

        `from None`: the openai exception carries the raw response (and our request headers).
        """
        label, status = self.config.label, error.status_code
        if status in (401, 403):
            raise ModelAuthError(
                f"{label} rejected the API key (HTTP {status}); check {self.config.key_setting}: {reason}"
            ) from None
        if status == 404:
            raise ModelNotFound(
                f"{label} answered HTTP 404: the model name or the base URL (the API root, usually "
                f"ending in /v1) is wrong: {reason}"
            ) from None
        if sent_parts and _CONTENT_PARTS_REFUSED.search(reason):
            raise ContentPartsRefused(
                f"{label} cannot take messages made of content parts (text + images) and answered "
                f"{reason!r}; it takes plain text only: {self.config.text_only_hint}"
            ) from None
        if status in _TRANSIENT_STATUSES:
            return
        if status < 500:
            raise ModelError(f"{label} refused the request: {reason}") from None
        if status == 501 or _DETERMINISTIC_SERVER_ERROR.search(reason):
            raise ModelError(
                f"{label} failed on this request in a way a retry would repeat (not retried): {reason}"
            ) from None

    def _completion(self, raw: Any) -> Any:
        """The parsed completion, after checking that the body is one (the openai package would
        hand back a bare string for a non-JSON body, and never checks the fields it reads)."""
        response = raw.http_response
        try:
            body = response.json()
        except ValueError:
            kind = response.headers.get("content-type") or "no content type"
            snippet = self.scrub(response.text[:200])
            raise ModelReplyMalformed(
                f"{self.config.label} replied with a body that is not JSON ({kind}): {snippet!r}"
            ) from None
        problem = completion_shape_problem(body)
        if problem:
            raise ModelReplyMalformed(
                f"{self.config.label} replied with JSON that is not a chat completion: {problem}"
            )
        return raw.parse()

    def _reply(self, completion: Any, started: float, attempts: int) -> ChatReply:
        if not completion.choices:
            raise ModelError(f"{self.config.label} returned no choices")
        message = completion.choices[0].message
        text = message.content
        if text is None:
            refusal = getattr(message, "refusal", None)
            reason = f"refused: {refusal}" if refusal else "returned no text content"
            raise ModelError(f"{self.config.label} {reason}")
        usage = None
        if completion.usage is not None:
            usage = TokenUsage(
                prompt_tokens=completion.usage.prompt_tokens,
                completion_tokens=completion.usage.completion_tokens,
                total_tokens=completion.usage.total_tokens,
            )
        return ChatReply(
            text=text,
            model=completion.model or self.config.model,
            usage=usage,
            finish_reason=completion.choices[0].finish_reason,
            latency_ms=(time.perf_counter() - started) * 1000.0,
            attempts=attempts,
        )


__all__ = [
    "ChatClient",
    "ChatModelConfig",
    "ChatReply",
    "ContentPartsRefused",
    "LLMError",
    "ModelAuthError",
    "ModelConfigurationError",
    "ModelError",
    "ModelNotFound",
    "ModelReplyMalformed",
    "ModelUnavailable",
    "TokenUsage",
    "as_text_only",
    "image_part",
    "plain_text_content",
    "scrub_secrets",
    "text_part",
]
