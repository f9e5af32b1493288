"""Choose the answer: with an answer model (vision), or offline from camera-motion text.

With a model: the answer prompt (question, the photos, the program and its output) goes out with a
JSON schema that constrains the answer to the option letters; servers that refuse structured output
are asked again without it, and a free-text reply is read for a letter (shared.questions.choices) or, failing
that, for the text of exactly one option.

Offline: a camera-motion sentence ("From view 1 to view 2 the camera moved diagonally forward and
right and turned left by about 45 degrees.") is compared with the options, wording normalized by
shared.questions.choices. Rendered images cannot be read without a vision model: the answer is then None with
the reason, never a guess.
"""

from __future__ import annotations

import json
import re
from typing import Any, Literal

from pydantic import BaseModel

from services.agent.llm import (
    ChatClient,
    LLMError,
    ModelConfigurationError,
    ModelError,
    image_part,
    text_part,
)
from services.agent.prompts import load_template
from shared.questions.choices import (
    extract_letter,
    normalize_direction,
    normalize_turn,
    turn_degrees,
)
from shared.questions.intent import QuestionIntent

AnswerMethod = Literal["model_json", "model_text", "model_option_text", "offline_text", "text_model", "none"]
DEFAULT_TEMPLATE = "answer_v1"
IMAGES_ONLY_TEMPLATE = "answer_images_only_v1"
VISION_MODEL_HINT = (
    "set PYSPATIAL_ANSWER_MODEL (and PYSPATIAL_ANSWER_MODEL_BASE_URL, PYSPATIAL_ANSWER_MODEL_API_KEY) "
    "to a vision-capable chat model"
)


class AnswerResult(BaseModel):
    answer: str | None  # an option letter, or None with `reason`
    reasoning: str = ""
    raw: str | None = None  # the model's reply, when a model answered
    method: AnswerMethod
    reason: str | None = None  # why there is no answer
    prompt_tokens: int = 0  # spent by the answer model, when one was asked
    completion_tokens: int = 0


def _with_usage(result: AnswerResult, reply: Any) -> AnswerResult:
    usage = getattr(reply, "usage", None)
    if usage is None:
        return result
    return result.model_copy(
        update={"prompt_tokens": usage.prompt_tokens or 0, "completion_tokens": usage.completion_tokens or 0}
    )


# ---- with a model --------------------------------------------------------------------------------


def answer_schema(letters: list[str]) -> dict[str, Any]:
    """response_format for structured output: reasoning first, then one of the option letters."""
    answer: dict[str, Any] = {"type": "string"}
    if letters:
        answer["enum"] = letters
    return {
        "type": "json_schema",
        "json_schema": {
            "name": "spatial_answer",
            "strict": True,
            "schema": {
                "type": "object",
                "properties": {"reasoning": {"type": "string"}, "answer": answer},
                "required": ["reasoning", "answer"],
                "additionalProperties": False,
            },
        },
    }


def _labelled_images(label: str, images: list[bytes]) -> list[dict[str, Any]]:
    parts: list[dict[str, Any]] = []
    for index, png in enumerate(images, start=1):
        parts.append(text_part(f"{label} {index}:"))
        parts.append(image_part(png))
    return parts


def build_answer_messages(
    intent: QuestionIntent,
    images_png: list[bytes],
    program: str,
    clue_text: str | None,
    clue_images: list[bytes],
    template_version: str = DEFAULT_TEMPLATE,
) -> list[dict[str, Any]]:
    letters = sorted(intent.options)
    content = load_template(template_version).render_parts(
        slots={
            "original_images": _labelled_images("Image", images_png),
            "clue_images": _labelled_images("Rendered view", clue_images),
        },
        question=intent.text,
        num_images=len(images_png),
        program=program.strip(),
        num_clue_images=len(clue_images),
        clue_text=clue_text.strip() if clue_text and clue_text.strip() else "(no text)",
        letters=", ".join(letters) if letters else "the options",
    )
    return [{"role": "user", "content": content}]


def _json_object(text: str) -> dict[str, Any] | None:
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


def _option_named(text: str, options: dict[str, str]) -> str | None:
    """The letter of the only option whose text the reply contains (whole words), else None."""
    named = [
        letter
        for letter, option in options.items()
        if option and re.search(rf"(?<!\w){re.escape(option.lower())}(?!\w)", text.lower())
    ]
    return named[0] if len(named) == 1 else None


def read_model_answer(text: str, options: dict[str, str]) -> AnswerResult:
    """Interpret an answer model's reply (JSON, a letter in prose, or an option's text)."""
    letters = sorted(options)
    valid = letters or None
    data = _json_object(text)
    if data is not None and "answer" in data:
        reasoning = str(data.get("reasoning") or "")
        stated = str(data["answer"]).strip()
        if not options:
            return AnswerResult(answer=stated or None, reasoning=reasoning, raw=text, method="model_json")
        letter = extract_letter(stated, valid) or _option_named(stated, options)
        if letter:
            return AnswerResult(answer=letter, reasoning=reasoning, raw=text, method="model_json")
    letter = extract_letter(text, valid)
    if letter:
        return AnswerResult(answer=letter, reasoning=text.strip(), raw=text, method="model_text")
    letter = _option_named(text, options)
    if letter:
        return AnswerResult(answer=letter, reasoning=text.strip(), raw=text, method="model_option_text")
    return AnswerResult(
        answer=None,
        reasoning=text.strip(),
        raw=text,
        method="none",
        reason=f"the answer model's reply names none of the options {', '.join(letters) or '(none parsed)'}",
    )


def answer_with_model(
    client: ChatClient,
    intent: QuestionIntent,
    images_png: list[bytes],
    program: str,
    clue_text: str | None,
    clue_images: list[bytes],
    template_version: str = DEFAULT_TEMPLATE,
) -> AnswerResult:
    """Ask the answer model; a model failure gives answer=None with the reason, not an exception."""
    options = intent.options
    messages = build_answer_messages(intent, images_png, program, clue_text, clue_images, template_version)
    try:
        try:
            reply = client.complete(messages, response_format=answer_schema(sorted(options)))
        except ModelConfigurationError:
            raise  # a rejected key or a text-only server: the client must see it (502), not a null
        except ModelError:
            # Many local servers refuse json_schema (a 4xx); the prompt asks for JSON anyway.
            reply = client.complete(messages)
    except ModelConfigurationError:
        raise
    except LLMError as error:
        return AnswerResult(answer=None, method="none", reason=f"the answer model failed: {error}")
    return _with_usage(read_model_answer(reply.text, options), reply)


# ---- a text-only model, for text clues ------------------------------------------------------------

TEXT_MODEL_NOTE = "Answered by a text-only model from the program's text output; it did not see the photos."


def answer_text_clue_with_model(
    client: ChatClient,
    intent: QuestionIntent,
    program: str,
    clue_text: str,
    template_version: str = "answer_text_v1",
) -> AnswerResult:
    """A text model reads a text clue (camera motion, turns) and picks an option, saying so.

    The model sees no images, so this is only for clues that are text. A model failure or a reply
    naming no option gives answer=None with the reason; a rejected key is raised.
    """
    options = intent.options
    letters = sorted(options)
    text = load_template(template_version).render(
        question=intent.text,
        program=program.strip(),
        clue_text=clue_text.strip(),
        letters=", ".join(letters) if letters else "the options",
    )
    try:
        reply = client.complete([{"role": "user", "content": text}])
    except ModelConfigurationError:
        raise
    except LLMError as error:
        return AnswerResult(answer=None, method="none", reason=f"the text model failed: {error}")
    read = _with_usage(read_model_answer(reply.text, options), reply)
    if read.answer is None:
        return read
    return read.model_copy(
        update={"method": "text_model", "reasoning": f"{TEXT_MODEL_NOTE} {read.reasoning}"}
    )


def answer_from_images(
    client: ChatClient,
    intent: QuestionIntent,
    images_png: list[bytes],
    template_version: str = IMAGES_ONLY_TEMPLATE,
) -> AnswerResult:
    """The answer model alone, from the question and the photos: the fallback when no program ran
    (the backbone could not reconstruct, or no program could be written or run), as the paper's code
    does. A model failure gives answer=None with the reason."""
    options = intent.options
    letters = sorted(options)
    content = load_template(template_version).render_parts(
        slots={"original_images": _labelled_images("Image", images_png)},
        question=intent.text,
        num_images=len(images_png),
        letters=", ".join(letters) if letters else "the options",
    )
    messages = [{"role": "user", "content": content}]
    try:
        try:
            reply = client.complete(messages, response_format=answer_schema(letters))
        except ModelError:
            reply = client.complete(messages)
    except LLMError as error:
        return AnswerResult(answer=None, method="none", reason=f"the answer model failed: {error}")
    return read_model_answer(reply.text, options)


# ---- offline -----------------------------------------------------------------------------------

_PAIR = re.compile(r"\b(?:view|image)\s+(\d+)\b.*?\b(?:view|image)\s+(\d+)\b", re.IGNORECASE)
_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z])")


class _Motion(BaseModel):
    pair: tuple[int, int] | None
    sentence: str
    direction: str | None
    turn: str | None
    degrees: float | None


def _motion_statements(clue_text: str) -> list[_Motion]:
    statements = []
    for line in clue_text.splitlines():
        for sentence in _SENTENCE_END.split(line.strip()):
            direction, turn = normalize_direction(sentence), normalize_turn(sentence)
            moved_or_not = re.search(r"\b(?:moved|stayed in place|neither moved)\b", sentence, re.IGNORECASE)
            if direction is None and turn is None and not moved_or_not:
                continue
            pair_match = _PAIR.search(sentence)
            pair = (int(pair_match.group(1)), int(pair_match.group(2))) if pair_match else None
            statements.append(
                _Motion(
                    pair=pair,
                    sentence=sentence.strip(),
                    direction=direction,
                    turn=turn,
                    degrees=turn_degrees(sentence),
                )
            )
    return statements


def _pick_statement(intent: QuestionIntent, statements: list[_Motion]) -> tuple[_Motion | None, str]:
    """The statement about the pair the question asks for (from its parsed intent), or None and why."""
    named = len(intent.mentioned_views) >= 2
    if intent.motion_pair is not None and (named or len(statements) > 1):
        for statement in statements:
            if statement.pair == intent.motion_pair:
                return statement, ""
        first, second = intent.motion_pair
        return None, f"the program's output has no sentence about view {first} to view {second}"
    if len(statements) == 1:
        return statements[0], ""
    return None, "the question does not say which pair of views it asks about"


def _option_motion(text: str, asks_turn_only: bool) -> tuple[str | None, str | None, float | None]:
    direction, turn, degrees = normalize_direction(text), normalize_turn(text), turn_degrees(text)
    if asks_turn_only and turn is None and direction is not None:
        # "Which way did I turn? A. Left B. Right": a bare side names the turn.
        if direction in ("left", "right"):
            return None, f"turn {direction}", degrees
        if direction == "backward":
            return None, "turn around", degrees if degrees is not None else 180.0
    return direction, turn, degrees


def _match_motion(
    intent: QuestionIntent, statement: _Motion, options: dict[str, str]
) -> tuple[str | None, str]:
    asks_turn_only = intent.asks_turn_only
    matches: list[tuple[str, float]] = []
    for letter, text in options.items():
        direction, turn, degrees = _option_motion(text, asks_turn_only)
        if direction is None and turn is None:
            continue
        if direction is not None and direction != statement.direction:
            continue
        if turn is not None and turn != statement.turn:
            continue
        gap = (
            abs(degrees - statement.degrees) if degrees is not None and statement.degrees is not None else 0.0
        )
        matches.append((letter, gap))
    if not matches:
        return None, f"no option states what the program's output says: {statement.sentence!r}"
    best = min(gap for _, gap in matches)
    closest = [letter for letter, gap in matches if gap == best]
    if len(closest) > 1:
        return None, f"options {', '.join(closest)} all fit the program's output {statement.sentence!r}"
    return closest[0], ""


def answer_offline(intent: QuestionIntent, clue_text: str | None, clue_images: list[bytes]) -> AnswerResult:
    """Answer from a camera-motion text clue without any model; None with the reason otherwise.

    The pair of views and whether a turn or a walk is asked come from the question's intent: never
    from the first view the question's opening happens to mention.
    """
    if not intent.options:
        return _no_answer("the question has no lettered options (A. ... B. ...) to choose from")
    text = (clue_text or "").strip()
    statements = _motion_statements(text) if text else []
    if statements:
        return _answer_from_motion(intent, statements)
    exact = [letter for letter, option in intent.options.items() if text and option.lower() == text.lower()]
    if len(exact) == 1:
        return AnswerResult(
            answer=exact[0],
            reasoning=f"The program's output is option {exact[0]}'s text, {intent.options[exact[0]]!r}.",
            method="offline_text",
        )
    return _no_answer(_unreadable_clue(text, clue_images))


def _no_answer(reason: str) -> AnswerResult:
    return AnswerResult(answer=None, method="none", reason=reason)


def _answer_from_motion(intent: QuestionIntent, statements: list[_Motion]) -> AnswerResult:
    """The option that states the motion the program's output describes for the asked pair."""
    if intent.family != "self_movement":
        return _no_answer(
            "the program's output describes camera motion, but this is a "
            f"{intent.family.replace('_', ' ')} question, which a motion sentence does not answer"
        )
    statement, why = _pick_statement(intent, statements)
    if statement is None:
        return _no_answer(why)
    letter, why = _match_motion(intent, statement, intent.options)
    if letter is None:
        return _no_answer(why)
    return AnswerResult(
        answer=letter,
        reasoning=f"The program's output says: {statement.sentence!r}. "
        f"Option {letter} ({intent.options[letter]!r}) states the same motion.",
        method="offline_text",
    )


def _unreadable_clue(text: str, clue_images: list[bytes]) -> str:
    """Why the offline answerer cannot read a clue that is no motion sentence and no option's text."""
    if clue_images:
        count = len(clue_images)
        return (
            f"the clue is {count} rendered view{'s' if count != 1 else ''}; answering from images "
            f"needs a vision model: {VISION_MODEL_HINT}"
        )
    if text:
        return (
            "the offline answerer only reads camera-motion sentences, and the program's output "
            f"is not one: {text[:200]!r}"
        )
    return "the program produced no clue (no text, no images)"


__all__ = [
    "AnswerMethod",
    "AnswerResult",
    "answer_from_images",
    "answer_offline",
    "answer_schema",
    "answer_text_clue_with_model",
    "answer_with_model",
    "build_answer_messages",
    "read_model_answer",
]
