"""The protocol's depth check (issue 38): exact on every frame, and the adversarial frames at the size
limit are parsed or refused as they should be. How long it takes is bench/protocol_parse.py's job."""

from __future__ import annotations

import json
import random

import pytest

from services.agent.sandbox.protocol import MAX_NESTING, ProtocolError, decode_message, nesting_depth
from services.agent.sandbox.worker_process import SandboxLimits

# The parent's cap on one frame from the worker, for the default limits (worker_process._converse).
FRAME_LIMIT = 24 * SandboxLimits().max_output_chars + (1 << 20)
# Text that looks like structure: brackets, quotes and backslashes inside strings must not count.
TRICKY_TEXT = ["[", "]{", '"', "\\", '\\"[', "}}", 'a"b"[', "\\\\", "x" * 40]


def depth_of(value: object) -> int:
    """The nesting of a decoded JSON value, by its own definition: containers count, nothing else."""
    if isinstance(value, list):
        return 1 + max((depth_of(item) for item in value), default=0)
    if isinstance(value, dict):
        return 1 + max((depth_of(item) for item in value.values()), default=0)
    return 0


def random_value(rng: random.Random, levels: int) -> object:
    choice = rng.randrange(6 if levels else 3)
    if choice == 0:
        return rng.choice(TRICKY_TEXT)
    if choice == 1:
        return rng.uniform(-1e6, 1e6)
    if choice == 2:
        return rng.choice([True, False, None])
    items = [random_value(rng, levels - 1) for _ in range(rng.randrange(4))]
    if choice in (3, 4):
        return items
    return {rng.choice(TRICKY_TEXT) + str(index): item for index, item in enumerate(items)}


def test_depth_is_the_nesting_of_the_value_for_random_frames() -> None:
    rng = random.Random(38)
    for _ in range(400):
        value = random_value(rng, rng.randrange(12))
        line = json.dumps(value, separators=(",", ":")).encode("ascii")
        assert nesting_depth(line) == depth_of(value), line


def test_strings_are_skipped_however_they_end() -> None:
    assert nesting_depth(b'["[[[", {"a": "]]]"}]') == 2
    assert nesting_depth(b'["\\\\", [["\\"["]]]') == 3  # an escaped backslash ends; an escaped quote does not
    assert nesting_depth(b'"[[[[') == 0  # a string that never closes hides everything after it
    assert nesting_depth(b'[["a\\') == 2  # a lone backslash at the very end
    assert nesting_depth(b"") == 0


def test_depth_carries_across_the_chunks_numpy_sums() -> None:
    gap = b" " * ((1 << 20) + 7)  # past one chunk
    assert nesting_depth(b"[" * 40 + gap + b"[" * 30 + gap + b"]" * 70) == 70
    assert nesting_depth(b"[" * 40 + gap + b"]" * 40 + gap + b"[" * 3) == 40


def test_the_unterminated_string_frame_at_the_size_limit_is_refused_as_malformed() -> None:
    frame = b'"' + b'\\"' * ((FRAME_LIMIT - 1) // 2)
    assert len(frame) <= FRAME_LIMIT
    assert nesting_depth(frame) == 0
    with pytest.raises(ProtocolError, match="malformed message: Unterminated string"):
        decode_message(frame)


def test_a_closed_string_of_escaped_quotes_at_the_size_limit_is_a_message() -> None:
    text = '"' * ((FRAME_LIMIT - 64) // 2)
    frame = json.dumps({"type": "result", "text": text}, separators=(",", ":")).encode("ascii")
    assert len(frame) <= FRAME_LIMIT
    assert nesting_depth(frame) == 1
    assert decode_message(frame) == {"type": "result", "text": text}


@pytest.mark.parametrize("extra", [0, 1])
def test_nesting_is_refused_just_past_the_limit(extra: int) -> None:
    levels = MAX_NESTING - 1 + extra  # inside the message object
    frame = b'{"type":"x","v":' + b"[" * levels + b"]" * levels + b"}"
    assert nesting_depth(frame) == MAX_NESTING + extra
    if extra:
        with pytest.raises(ProtocolError, match=f"nested more than {MAX_NESTING} levels"):
            decode_message(frame)
    else:
        assert depth_of(decode_message(frame)) == MAX_NESTING


def test_brackets_at_the_size_limit_are_refused_by_depth_not_parsed() -> None:
    frame = b"[" * FRAME_LIMIT
    assert nesting_depth(frame) == FRAME_LIMIT
    with pytest.raises(ProtocolError, match="nested more than"):
        decode_message(frame)
