"""The one answer module for camera questions: the reading's claims against the measured motion.

Given a question's reading (shared/questions/reading.py) and the motion sentence the program
measured for the asked pair (read by motion_clue.py: exact, or over every focal hypothesis with its
ranges and determinacy marks), `match_claims` returns the one option that holds at every
hypothesis while no other does, or no answer with the reason (and the range, when the photos do
not determine it). The sentence's axes are the start view's; a question asked in another frame is
answered only where its claims read the same there (asked_frame.py), else refused naming the frame.
Claims are compared quantity by quantity: a translation claim looks only at the
step, so a sentence that also reports a turn does not block it; a position claim is the step too
(the second camera's centre in the first camera's frame).

Of several options that hold at a hypothesis, the nearest wins there (a step's compass sector is 45
degrees either side of its direction, then the stated degrees); the answer must be the same option
at every hypothesis.
"""

from __future__ import annotations

import math

from pydantic import BaseModel

from services.agent.asked_frame import frame_refusal, in_asked_frame
from services.agent.motion_clue import (
    NO_GRAVITY_OVER_FOCAL,
    UNDETERMINED,
    Hypothetical,
    MotionStatement,
    hypothetical_readings,
    motion_statements,
)
from shared.questions.choices import DIRECTIONS
from shared.questions.claims import Unread, as_motion_reading, is_read
from shared.questions.intent import QuestionIntent
from shared.questions.motion_words import AskedMotion, MotionReading, agrees
from shared.questions.reading import QuestionReading, read_question


class ClaimMatch(BaseModel, frozen=True):
    """The matched option letter, or None with the reason (and the measured range when undetermined)."""

    letter: str | None
    reason: str | None = None
    range: str | None = None  # the sentence's words for what the photos leave open
    determined: bool = True


def _asked(reading: QuestionReading, claims: dict[str, MotionReading]) -> AskedMotion:
    """Which angle's degrees matter for the hypotheses (tilt, roll, else turn)."""
    if any(c.tilt not in (None, "no tilt") for c in claims.values()):
        return "tilt"
    if any(c.roll not in (None, "no roll") for c in claims.values()):
        return "roll"
    return "turn" if reading.quantity == "rotation" else "any"


def question_reading(intent: QuestionIntent) -> QuestionReading:
    """The reading made when the question was parsed (read again from its text only for an intent
    built by hand)."""
    return intent.reading or read_question(intent.text)


def read_by_claims(intent: QuestionIntent, clue_text: str | None) -> bool:
    """Whether the offline answer to this question is the claims' match: a camera question with
    options read as claims, whose clue holds a camera-motion sentence (its abstention then stands;
    no text model is asked). Options the lexicon reads none of ("toward the door") are left to one."""
    reading = question_reading(intent)
    read = any(is_read(claim) for claim in reading.options.values())
    return reading.is_camera and read and bool(motion_statements(clue_text or ""))


def pick_pair_statement(
    reading: QuestionReading, statements: list[MotionStatement]
) -> tuple[MotionStatement | None, str]:
    """The sentence about the pair the reading asks (a single unlabelled sentence is taken as it)."""
    if reading.views is None:
        return None, reading.abstain_reason or "the question does not say which two photos it compares"
    for statement in statements:
        if statement.pair == reading.views:
            return statement, ""
    if len(statements) == 1 and statements[0].pair is None:
        return statements[0], ""
    first, second = reading.views
    return None, f"the program's output has no sentence about view {first} to view {second}"


def match_sentence(reading: QuestionReading, text: str) -> ClaimMatch:
    """`match_claims` on the sentence about the asked pair in a program's (or recon's) text."""
    statement, why = pick_pair_statement(reading, motion_statements(text or ""))
    if statement is None:
        return ClaimMatch(letter=None, reason=why)
    return match_claims(reading, statement)


def match_claims(reading: QuestionReading, statement: MotionStatement) -> ClaimMatch:
    """The one option that holds at every hypothesis and no other does, else None and why."""
    if reading.abstain_reason is not None:
        return ClaimMatch(letter=None, reason=reading.abstain_reason)
    claims = {letter: as_motion_reading(claim) for letter, claim in reading.options.items()}
    unread = [letter for letter, claim in reading.options.items() if isinstance(claim, Unread)]
    read = {letter: claim for letter, claim in claims.items() if claim is not None}
    if not read:
        return ClaimMatch(letter=None, reason="no option reads as a camera claim")
    stated = {key for claim in read.values() for key in claim.stated()}
    if (refused := frame_refusal(reading, statement, stated)) is not None:
        return ClaimMatch(letter=None, reason=refused)  # never an answer in another frame's axes
    gravity = reading.frame is not None and reading.frame.kind == "room"
    if statement.over_focal is not None:
        if gravity:
            return ClaimMatch(
                letter=None, reason=f"{UNDETERMINED}: {NO_GRAVITY_OVER_FOCAL}", determined=False
            )
        variants = hypothetical_readings(
            statement.over_focal,
            _asked(reading, read),
            stated,
            any(claim.degrees is not None for claim in read.values()),
        )
    else:
        said = in_asked_frame(reading, statement, statement.reading_for("gravity" if gravity else "image"))
        variants = [Hypothetical(said, None)]
    nearest = [_nearest(read, variant) for variant in variants]
    letters = {best[0] if len(best) == 1 else None for best, _ in nearest}
    if len(letters) == 1 and None not in letters:
        letter = letters.pop()
        assert letter is not None
        exact = all(gap == 0.0 for _, gap in nearest)
        if unread and not exact:
            return ClaimMatch(
                letter=None,
                reason=f"option {', '.join(unread)} could not be read, and the others do not decide "
                "the answer",
            )
        return ClaimMatch(letter=letter)
    named = sorted({letter for best, _ in nearest for letter in best})
    if statement.over_focal is None:
        if named:
            return ClaimMatch(
                letter=None, reason=f"options {', '.join(named)} all fit {statement.sentence!r}"
            )
        return ClaimMatch(
            letter=None, reason=f"no option states what the program's output says: {statement.sentence!r}"
        )
    fits = f"options {', '.join(named)} each fit some of them" if named else "no option fits all of them"
    return ClaimMatch(
        letter=None,
        reason=f"{UNDETERMINED}: {statement.sentence} ({fits})",
        range=statement.sentence,
        determined=False,
    )


_SECTOR_DEG = 45.0


def _heading_gap(direction: str, variant: Hypothetical) -> float:
    """How far a claimed compass direction is from a hypothetical step (inf: it did not step)."""
    if variant.reading.direction is None:
        return math.inf
    if variant.heading_deg is None:
        if direction == variant.reading.direction:
            return 0.0
        gap = abs(DIRECTIONS.index(direction) - DIRECTIONS.index(variant.reading.direction)) % 8
        return min(gap, 8 - gap) * _SECTOR_DEG
    offset = DIRECTIONS.index(direction) * _SECTOR_DEG - variant.heading_deg
    return abs((offset + 180.0) % 360.0 - 180.0)


def _nearest(claims: dict[str, MotionReading], variant: Hypothetical) -> tuple[tuple[str, ...], float]:
    """The claims that hold at a hypothetical motion and are nearest to it (one, several on a tie,
    none), with their heading gap (0 when they state the step's own sector, or no step)."""
    scored = []
    for letter, claim in claims.items():
        stated = claim.stated()
        rest = claim.model_copy(update={"direction": None})
        if rest.stated() and not agrees(rest, variant.reading)[0]:
            continue
        heading_gap = 0.0 if claim.direction is None else _heading_gap(claim.direction, variant)
        if heading_gap > _SECTOR_DEG:
            continue
        said = variant.reading.degrees
        degree_gap = abs(claim.degrees - said) if claim.degrees is not None and said is not None else 0.0
        scored.append((heading_gap, degree_gap, -len(stated), letter))
    if not scored:
        return (), math.inf
    best = min(scored)[:3]
    return tuple(entry[3] for entry in scored if entry[:3] == best), best[0]


__all__ = [
    "ClaimMatch",
    "match_claims",
    "match_sentence",
    "pick_pair_statement",
    "question_reading",
    "read_by_claims",
]
