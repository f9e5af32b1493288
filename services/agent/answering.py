"""Choose the answer: with an answer model (vision), or offline from camera-motion text.

With a model: the answer prompt (question, the photos, the program and its output) goes out with a
JSON schema that constrains the answer to the option letters; servers that refuse structured output
are asked again without it, and a free-text reply is read for a letter (shared.questions.choices) or, failing
that, for the text of exactly one option.

Offline: a camera-motion sentence ("From view 1 to view 2 the camera moved diagonally forward and
right and turned left by about 45 degrees.") is compared with the options, wording normalized by
shared.questions.choices. Rendered images cannot be read without a vision model: the answer is then None with
the reason, never a guess.

A question without options is answered in words (services/agent/free_form.py: its prompts, how its
replies are read, its offline rule); every function here hands such questions to it.
"""

from __future__ import annotations

from typing import Any

from services.agent import free_form
from services.agent.answer_result import AnswerMethod, AnswerResult, json_object, no_answer, with_usage
from services.agent.claim_matching import match_claims, pick_pair_statement, question_reading
from services.agent.llm import (
    ChatClient,
    LLMError,
    ModelConfigurationError,
    ModelError,
    image_part,
    text_part,
)
from services.agent.motion_clue import (
    UNDETERMINED,
    VISION_MODEL_HINT,
    MotionStatement,
    motion_statements,
    not_a_motion_question,
    unreadable_clue,
)
from services.agent.prompts import load_template
from shared.questions.choices import read_choice
from shared.questions.intent import QuestionIntent

DEFAULT_TEMPLATE = "answer_v1"
IMAGES_ONLY_TEMPLATE = "answer_images_only_v1"


def _letter_fields(intent: QuestionIntent) -> dict[str, str]:
    """The `letters` a multiple-choice prompt names; free-form prompts have no such field."""
    if free_form.is_free_form(intent):
        return {}
    return {"letters": ", ".join(sorted(intent.options))}


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
    content = load_template(free_form.template_for(intent, template_version)).render_parts(
        slots={
            "original_images": _labelled_images("Image", images_png),
            "clue_images": _labelled_images("Rendered view", clue_images),
        },
        question=intent.text,
        num_images=len(images_png),
        program=program.strip(),
        num_clue_images=len(clue_images),
        clue_text=clue_text.strip() if clue_text and clue_text.strip() else "(no text)",
        **_letter_fields(intent),
    )
    return [{"role": "user", "content": content}]


def read_model_answer(text: str, options: dict[str, str]) -> AnswerResult:
    """Interpret an answer model's reply (JSON, a letter in prose, or an option's text); with no
    options, the reply is a free-form answer (services/agent/free_form.py)."""
    if not options:
        return free_form.read_reply(text)
    letters = sorted(options)
    data = json_object(text)
    if data is not None and "answer" in data:
        reasoning = str(data.get("reasoning") or "")
        letter = read_choice(str(data["answer"]).strip(), options)
        if letter:
            return AnswerResult(answer=letter, reasoning=reasoning, raw=text, method="model_json")
    letter = read_choice(text, letters)
    if letter:
        return AnswerResult(answer=letter, reasoning=text.strip(), raw=text, method="model_text")
    letter = read_choice(text, options)  # no letter named: the only option whose text it names
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
    return with_usage(read_model_answer(reply.text, options), reply)


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
    text = load_template(free_form.template_for(intent, template_version)).render(
        question=intent.text, program=program.strip(), clue_text=clue_text.strip(), **_letter_fields(intent)
    )
    try:
        reply = client.complete([{"role": "user", "content": text}])
    except ModelConfigurationError:
        raise
    except LLMError as error:
        return AnswerResult(answer=None, method="none", reason=f"the text model failed: {error}")
    read = with_usage(read_model_answer(reply.text, options), reply)
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
    content = load_template(free_form.template_for(intent, template_version)).render_parts(
        slots={"original_images": _labelled_images("Image", images_png)},
        question=intent.text,
        num_images=len(images_png),
        **_letter_fields(intent),
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


def answer_offline(intent: QuestionIntent, clue_text: str | None, clue_images: list[bytes]) -> AnswerResult:
    """Answer from a camera-motion text clue without any model; None with the reason otherwise.

    The pair of views and whether a turn or a walk is asked come from the question's intent: never
    from the first view the question's opening happens to mention.
    """
    if free_form.is_free_form(intent):
        return free_form.answer_offline(intent, clue_text, clue_images)
    text = (clue_text or "").strip()
    statements = motion_statements(text) if text else []
    if statements:
        return _answer_from_motion(intent, statements)
    exact = [letter for letter, option in intent.options.items() if text and option.lower() == text.lower()]
    if len(exact) == 1:
        return AnswerResult(
            answer=exact[0],
            reasoning=f"The program's output is option {exact[0]}'s text, {intent.options[exact[0]]!r}.",
            method="offline_text",
        )
    return no_answer(unreadable_clue(text, clue_images))


def _answer_from_motion(intent: QuestionIntent, statements: list[MotionStatement]) -> AnswerResult:
    """The option whose claim holds for the motion the program measured for the asked pair, read
    through the question's one reading (services/agent/claim_matching.py)."""
    reading = question_reading(intent)
    why = not_a_motion_question(intent, reading)
    if why is not None:
        return no_answer(why)
    statement, why = pick_pair_statement(reading, statements)
    if statement is None:
        return no_answer(why)
    match = match_claims(reading, statement)
    if match.letter is None:
        return no_answer(f"{match.reason} ({reading.summary})")
    letter = match.letter
    everywhere = " at every focal length the photos allow" if statement.over_focal is not None else ""
    return AnswerResult(
        answer=letter,
        reasoning=f"{reading.summary[0].upper()}{reading.summary[1:]}. The program's output says: "
        f"{statement.sentence!r}. Option {letter} ({intent.options[letter]!r}, read as "
        f"{reading.options[letter].words}) holds{everywhere}, and no other option does.",
        method="offline_text",
    )


__all__ = [
    "UNDETERMINED",
    "VISION_MODEL_HINT",
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
