"""A chat client for any OpenAI-compatible endpoint (OpenAI, vLLM, Ollama, llama.cpp server).

The `openai` package does the HTTP; retries are ours (the package's own are switched off) so that
every attempt is counted, Retry-After is honoured, and the final error names the endpoint, the
model and the reason. Retried: 429, 5xx, timeouts and connection failures. Not retried: other 4xx,
which mean the request itself is wrong and would fail again.
"""

from __future__ import annotations

import base64
import email.utils
import random
import time
from collections.abc import Callable
from typing import Any

import openai
from pydantic import BaseModel, Field, SecretStr

# Local servers (vLLM, Ollama, llama.cpp) ignore the key, but the openai package insists on one.
_PLACEHOLDER_KEY = "not-needed"


class LLMError(RuntimeError):
    """Base class of chat model failures."""


class ModelUnavailable(LLMError):  # noqa: N818 (the name reads better than ModelUnavailableError)
    """The endpoint could not be reached or kept failing (429, 5xx, timeouts) through every retry."""


class ModelError(LLMError):
    """The endpoint refused the request (4xx other than 429) or replied with something unusable."""


class ChatModelConfig(BaseModel):
    base_url: str = Field(description="OpenAI-compatible API root, e.g. http://127.0.0.1:8000/v1")
    model: str
    api_key: SecretStr | None = None
    timeout_s: float = Field(60.0, gt=0)
    max_retries: int = Field(3, ge=0, description="Extra attempts after the first one.")
    temperature: float = Field(0.0, ge=0.0, le=2.0)
    max_tokens: int | None = Field(None, ge=1)
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
    latency_ms: float = Field(description="Wall time of the whole call, retries and waits included.")
    attempts: int


def text_part(text: str) -> dict[str, Any]:
    return {"type": "text", "text": text}


def image_part(png_bytes: bytes, mime_type: str = "image/png") -> dict[str, Any]:
    """An image content part carrying the bytes inline as a base64 data URL."""
    encoded = base64.b64encode(png_bytes).decode("ascii")
    return {"type": "image_url", "image_url": {"url": f"data:{mime_type};base64,{encoded}"}}


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


class ChatClient:
    """Chat completions with counted retries; one instance per configured model."""

    def __init__(self, config: ChatModelConfig, sleep: Callable[[float], None] = time.sleep) -> None:
        self.config = config
        self._sleep = sleep
        api_key = config.api_key.get_secret_value() if config.api_key else _PLACEHOLDER_KEY
        self._client = openai.OpenAI(
            base_url=config.base_url, api_key=api_key, timeout=config.timeout_s, max_retries=0
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

    def complete(
        self, messages: list[dict[str, Any]], response_format: dict[str, Any] | None = None
    ) -> ChatReply:
        """One chat completion. Raises ModelUnavailable or ModelError (see the module docstring)."""
        config = self.config
        options: dict[str, Any] = {"temperature": config.temperature}
        if config.max_tokens is not None:
            options["max_tokens"] = config.max_tokens
        if response_format is not None:
            options["response_format"] = response_format
        started = time.perf_counter()
        total_attempts = config.max_retries + 1
        last_reason = ""
        for attempt in range(1, total_attempts + 1):
            wait_s: float | None = None
            try:
                completion = self._client.chat.completions.create(
                    model=config.model, messages=messages, **options
                )
            except openai.APITimeoutError:
                last_reason = f"timed out after {config.timeout_s:g}s"
            except openai.APIConnectionError as error:
                last_reason = f"connection failed ({error.__cause__ or error.message})"
            except openai.APIStatusError as error:
                last_reason = _status_detail(error)
                if error.status_code != 429 and error.status_code < 500:
                    raise ModelError(f"{config.label} refused the request: {last_reason}") from error
                wait_s = _retry_after_s(error)
                if wait_s is not None and wait_s > config.max_retry_after_s:
                    raise ModelUnavailable(
                        f"{config.label} asked us to retry after {wait_s:.0f}s, more than the "
                        f"{config.max_retry_after_s:g}s we wait: {last_reason}"
                    ) from error
            else:
                return self._reply(completion, started, attempt)
            if attempt == total_attempts:
                break
            # A server's Retry-After wins; a little jitter keeps clients from returning in lockstep.
            delay = wait_s * (1.0 + 0.1 * random.random()) if wait_s is not None else self._backoff_s(attempt)
            self._sleep(delay)
        raise ModelUnavailable(f"{config.label} failed after {total_attempts} attempt(s): {last_reason}")

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
            latency_ms=(time.perf_counter() - started) * 1000.0,
            attempts=attempts,
        )


__all__ = [
    "ChatClient",
    "ChatModelConfig",
    "ChatReply",
    "LLMError",
    "ModelError",
    "ModelUnavailable",
    "TokenUsage",
    "image_part",
    "text_part",
]
