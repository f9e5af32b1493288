"""What an answerer produced: the answer (an option letter, or words for a free-form question), or
None with the reason, and how it was reached (`method`)."""

from __future__ import annotations

import json
import re
from typing import Any, Literal

from pydantic import BaseModel

AnswerMethod = Literal[
    "model_json", "model_text", "model_option_text", "offline_text", "text_model", "model_free_text", "none"
]


class AnswerResult(BaseModel):
    answer: str | None  # an option letter, words (free-form questions), or None with `reason`
    reasoning: str = ""
    raw: str | None = None  # the model's reply, when a model answered
    method: AnswerMethod
    reason: str | None = None  # why there is no answer
    prompt_tokens: int = 0  # spent by the answer model, when one was asked
    completion_tokens: int = 0


def with_usage(result: AnswerResult, reply: Any) -> AnswerResult:
    """`result` with the tokens the model's `reply` spent."""
    usage = getattr(reply, "usage", None)
    if usage is None:
        return result
    return result.model_copy(
        update={"prompt_tokens": usage.prompt_tokens or 0, "completion_tokens": usage.completion_tokens or 0}
    )


def json_object(text: str) -> dict[str, Any] | None:
    """The first JSON object in a reply: bare, inside ```json fences, or amid prose."""
    decoder = json.JSONDecoder()
    for start in [match.start() for match in re.finditer(r"\{", text)]:
        try:
            value, _ = decoder.raw_decode(text, start)
        except json.JSONDecodeError:
            continue
        if isinstance(value, dict):
            return value
    return None


def no_answer(reason: str) -> AnswerResult:
    return AnswerResult(answer=None, method="none", reason=reason)


__all__ = ["AnswerMethod", "AnswerResult", "json_object", "no_answer", "with_usage"]
