"""ChatClient against a real OpenAI-compatible server process that replays scripted replies."""

from __future__ import annotations

import time

import httpx
import pytest

from services.agent.llm import (
    ChatClient,
    ChatModelConfig,
    ContentPartsRefused,
    ModelAuthError,
    ModelError,
    ModelNotFound,
    ModelUnavailable,
    image_part,
    scrub_secrets,
    text_part,
)
from tests.support.processes import free_port
from tests.support.scripted_llm import ScriptedLLM, start_scripted_llm


@pytest.fixture(autouse=True)
def fresh_script(llm: ScriptedLLM) -> None:
    llm.reset()


def make_client(base_url: str, **overrides: object) -> ChatClient:
    settings = {"base_url": base_url, "model": "test-model", "timeout_s": 5.0, "backoff_base_s": 0.05}
    settings.update(overrides)
    return ChatClient(ChatModelConfig(**settings))


def test_normal_reply_and_recorded_request(llm: ScriptedLLM) -> None:
    llm.script(["Hello there."])
    with make_client(llm.base_url, max_tokens=50) as client:
        reply = client.complete([{"role": "user", "content": [text_part("Hi"), image_part(b"\x89PNG fake")]}])
    assert reply.text == "Hello there."
    assert reply.model == "test-model"
    assert reply.attempts == 1
    assert reply.usage is not None and reply.usage.completion_tokens == 2
    assert reply.latency_ms > 0
    (request,) = llm.requests()
    assert request["model"] == "test-model"
    assert request["body"]["max_tokens"] == 50
    assert request["body"]["temperature"] == 0.0
    parts = request["messages"][0]["content"]
    assert parts[0] == {"type": "text", "text": "Hi"}
    assert parts[1]["image_url"]["url"].startswith("data:image/png;base64,")


def test_response_format_is_sent(llm: ScriptedLLM) -> None:
    llm.script(['{"answer": "A"}'])
    response_format = {"type": "json_object"}
    with make_client(llm.base_url) as client:
        client.complete([{"role": "user", "content": "x"}], response_format=response_format)
    assert llm.requests()[0]["response_format"] == response_format


def test_429_then_success_honours_retry_after(llm: ScriptedLLM) -> None:
    llm.script([{"status": 429, "retry_after": 1}, "after the wait"])
    with make_client(llm.base_url, backoff_base_s=0.0) as client:
        started = time.monotonic()
        reply = client.complete([{"role": "user", "content": "x"}])
        waited = time.monotonic() - started
    assert reply.text == "after the wait"
    assert reply.attempts == 2
    assert waited >= 1.0  # the backoff alone would have been 0 s
    assert len(llm.requests()) == 2


def test_retry_after_longer_than_allowed_gives_up_at_once(llm: ScriptedLLM) -> None:
    llm.script([{"status": 429, "retry_after": 300}, "never read"])
    with make_client(llm.base_url, max_retry_after_s=5) as client, pytest.raises(ModelUnavailable) as failure:
        client.complete([{"role": "user", "content": "x"}])
    assert "300" in str(failure.value) and "test-model" in str(failure.value)
    assert len(llm.requests()) == 1


def test_500_then_success(llm: ScriptedLLM) -> None:
    llm.script([{"status": 500, "error_message": "overloaded"}, {"status": 503}, "recovered"])
    with make_client(llm.base_url) as client:
        reply = client.complete([{"role": "user", "content": "x"}])
    assert reply.text == "recovered"
    assert reply.attempts == 3


def test_persistent_500_exhausts_retries(llm: ScriptedLLM) -> None:
    llm.script([{"status": 500, "error_message": "overloaded"}] * 3)
    with make_client(llm.base_url, max_retries=2) as client, pytest.raises(ModelUnavailable) as failure:
        client.complete([{"role": "user", "content": "x"}])
    message = str(failure.value)
    assert "3 attempt(s)" in message and "HTTP 500" in message and "overloaded" in message
    assert llm.base_url in message


def test_timeout_is_retried_then_model_unavailable(llm: ScriptedLLM) -> None:
    llm.script([{"delay_s": 3, "text": "too late"}, {"delay_s": 3, "text": "too late again"}])
    with make_client(llm.base_url, timeout_s=0.5, max_retries=1) as client:
        with pytest.raises(ModelUnavailable) as failure:
            client.complete([{"role": "user", "content": "x"}])
    assert "timed out after 0.5s" in str(failure.value)
    assert "2 attempt(s)" in str(failure.value)
    assert len(llm.requests()) == 2


def test_timeout_then_success(llm: ScriptedLLM) -> None:
    llm.script([{"delay_s": 3, "text": "too late"}, "in time"])
    with make_client(llm.base_url, timeout_s=0.5) as client:
        reply = client.complete([{"role": "user", "content": "x"}])
    assert reply.text == "in time"
    assert reply.attempts == 2


def test_400_is_not_retried(llm: ScriptedLLM) -> None:
    llm.script([{"status": 400, "error_message": "response_format json_schema is not supported"}, "unused"])
    with make_client(llm.base_url) as client, pytest.raises(ModelError) as failure:
        client.complete([{"role": "user", "content": "x"}])
    message = str(failure.value)
    assert "refused the request" in message and "HTTP 400" in message and "json_schema" in message
    assert len(llm.requests()) == 1


def test_unreachable_endpoint_is_model_unavailable() -> None:
    base_url = f"http://127.0.0.1:{free_port()}/v1"  # nothing listens there
    with make_client(base_url, max_retries=1) as client, pytest.raises(ModelUnavailable) as failure:
        client.complete([{"role": "user", "content": "x"}])
    assert "connection failed" in str(failure.value) and base_url in str(failure.value)


def test_per_model_queues_and_models_listing(llm: ScriptedLLM) -> None:
    llm.script(["from the default queue"])
    llm.script(["for the coder"], model="coder")
    with make_client(llm.base_url, model="coder") as coder, make_client(llm.base_url, model="other") as other:
        assert coder.complete([{"role": "user", "content": "x"}]).text == "for the coder"
        assert other.complete([{"role": "user", "content": "x"}]).text == "from the default queue"
    listed = httpx.get(llm.base_url + "/models", timeout=5).json()
    assert [model["id"] for model in listed["data"]] == ["coder"]


def test_exhausted_script_is_a_clear_model_error(llm: ScriptedLLM) -> None:
    with make_client(llm.base_url) as client, pytest.raises(ModelError, match="no reply left"):
        client.complete([{"role": "user", "content": "x"}])


def test_script_loaded_at_process_start() -> None:
    server = start_scripted_llm({"default": ["first"], "models": {"m": ["for m"]}})
    try:
        with make_client(server.base_url, model="m") as client:
            assert client.complete([{"role": "user", "content": "x"}]).text == "for m"
            assert client.complete([{"role": "user", "content": "x"}]).text == "first"
    finally:
        server.stop()


# ---- endpoints as they are ----------------------------------------------------------------------

SECRET = "sk-test-SECRET0123456789abcdef"


def test_text_only_model_gets_plain_string_content(llm: ScriptedLLM) -> None:
    llm.text_only()
    llm.script(["fine"])
    parts = [text_part("Look:"), image_part(b"\x89PNG fake"), text_part("What is it?")]
    with make_client(llm.base_url, text_only=True) as client:
        assert client.complete([{"role": "user", "content": parts}]).text == "fine"
    (request,) = llm.requests()
    content = request["messages"][0]["content"]
    assert isinstance(content, str) and content.startswith("Look:\n") and content.endswith("What is it?")
    assert "base64" not in content and "image was left out" in content


def test_a_server_that_refuses_content_parts_is_reported_at_once(llm: ScriptedLLM) -> None:
    llm.text_only()
    llm.script(["never sent"])
    hint = "set PYSPATIAL_CODE_MODEL_TEXT_ONLY=true"
    with make_client(llm.base_url, max_retries=3, text_only_hint=hint) as client:
        with pytest.raises(ContentPartsRefused) as refused:
            client.complete([{"role": "user", "content": [text_part("x")]}])
    message = str(refused.value)
    assert "can only concatenate str" in message and hint in message and "test-model" in message
    assert len(llm.requests()) == 1  # deterministic: not retried as if transient


def test_deterministic_server_errors_are_not_retried_and_transient_ones_are(llm: ScriptedLLM) -> None:
    llm.script([{"status": 500, "error_message": "TypeError: 'NoneType' object is not subscriptable"}, "x"])
    with make_client(llm.base_url, max_retries=3) as client, pytest.raises(ModelError) as failure:
        client.complete([{"role": "user", "content": "x"}])
    assert "not retried" in str(failure.value) and len(llm.requests()) == 1
    llm.reset()
    llm.script([{"status": 502}, {"status": 504}, {"status": 408}, "through"])
    with make_client(llm.base_url, max_retries=3) as client:
        assert client.complete([{"role": "user", "content": "x"}]).attempts == 4


@pytest.mark.parametrize("status", [401, 403])
def test_a_rejected_key_is_an_auth_error_without_the_key(llm: ScriptedLLM, status: int) -> None:
    llm.script(
        [{"status": status, "error_message": "Invalid credentials in header Authorization: {authorization}"}]
    )
    with make_client(llm.base_url, api_key=SECRET, max_retries=3) as client:
        with pytest.raises(ModelAuthError) as failure:
            client.complete([{"role": "user", "content": "x"}])
    message = str(failure.value)
    assert f"HTTP {status}" in message and "rejected the API key" in message
    assert SECRET not in message and "SECRET0123" not in message and "[redacted]" in message
    assert len(llm.requests()) == 1


def test_transient_errors_that_echo_the_key_are_scrubbed(llm: ScriptedLLM) -> None:
    echo = {"status": 503, "error_message": "upstream busy; request had Authorization: {authorization}"}
    llm.script([echo, echo])
    with make_client(llm.base_url, api_key=SECRET, max_retries=1) as client:
        with pytest.raises(ModelUnavailable) as failure:
            client.complete([{"role": "user", "content": "x"}])
    assert SECRET not in str(failure.value) and "[redacted]" in str(failure.value)
    assert failure.value.__cause__ is None  # the openai exception (with our headers) is not chained


@pytest.mark.parametrize(
    "text",
    [
        f"Authorization: Bearer {SECRET}",
        f'{{"headers": {{"authorization": "Bearer {SECRET}"}}}}',
        f"GET /v1/models?api_key={SECRET}&x=1",
        f"the key {SECRET} is not valid",
        "x-api-key: abcdef123456",
    ],
)
def test_scrub_secrets(text: str) -> None:
    scrubbed = scrub_secrets(text)
    assert "[redacted]" in scrubbed and "SECRET0123" not in scrubbed and "abcdef123456" not in scrubbed
    assert scrub_secrets('HTTP 500: can only concatenate str (not "list") to str') == (
        'HTTP 500: can only concatenate str (not "list") to str'
    )


def test_finish_reason_and_temperature_override(llm: ScriptedLLM) -> None:
    llm.script(
        [{"text": "cut", "finish_reason": "length", "usage": {"prompt_tokens": 7, "completion_tokens": 3}}]
    )
    with make_client(llm.base_url, max_tokens=3) as client:
        reply = client.complete([{"role": "user", "content": "x"}], temperature=0.6)
    assert reply.finish_reason == "length" and reply.usage.prompt_tokens == 7
    body = llm.requests()[0]["body"]
    assert body["temperature"] == 0.6 and body["max_tokens"] == 3


def test_an_unknown_model_is_a_configuration_error(llm: ScriptedLLM) -> None:
    llm.script([{"status": 404, "error_message": "The model `qwen-7b` does not exist"}])
    with make_client(llm.base_url, max_retries=2) as client, pytest.raises(ModelNotFound) as failure:
        client.complete([{"role": "user", "content": "x"}])
    assert "HTTP 404" in str(failure.value) and "does not exist" in str(failure.value)
    assert len(llm.requests()) == 1
