"""Demo code is dropped before validation; what program() uses stays, and unsafe code stays refused."""

from __future__ import annotations

import pytest

from services.agent.program_cleanup import clean_program, program_fingerprint
from services.agent.sandbox.validation import ProgramRejected, validate_program

PROGRAM = "def program(input_scene):\n    return helper(LIMIT)\n"


def test_helpers_constants_and_sandbox_imports_stay() -> None:
    source = (
        "import numpy as np\nfrom math import atan2\n\nLIMIT = 3\nUNUSED = 4\n\n"
        "def helper(x):\n    return scale(x) + OFFSET\n\ndef scale(x):\n    return 2 * x\n\nOFFSET = 1\n\n"
        + PROGRAM
    )
    cleaned = clean_program(source)
    for kept in (
        "import numpy as np",
        "from math import atan2",
        "LIMIT = 3",
        "def helper",
        "def scale",
        "OFFSET = 1",
    ):
        assert kept in cleaned.source
    assert "UNUSED" not in cleaned.source
    assert cleaned.dropped == ["line 5: UNUSED = 4 (top-level code program() does not use)"]


def test_unsafe_code_that_program_uses_is_kept_for_the_validator_to_refuse() -> None:
    source = "import os\n\ndef program(input_scene):\n    return os.listdir('/')\n"
    cleaned = clean_program(source)
    assert cleaned.source == source and cleaned.dropped == []
    with pytest.raises(ProgramRejected, match="imports are not allowed"):
        validate_program(cleaned.source)
    escape = "def program(input_scene):\n    return ().__class__\n\nprint(program(None))\n"
    with pytest.raises(ProgramRejected, match="__class__"):
        validate_program(clean_program(escape).source)


def test_an_unused_import_and_top_level_loops_go() -> None:
    source = (
        "import subprocess\n\n"
        + "def program(input_scene):\n    return 1\n\n"
        + "for i in range(3):\n    print(i)\n"
    )
    cleaned = clean_program(source)
    assert cleaned.source == "def program(input_scene):\n    return 1\n"
    assert (
        cleaned.dropped[0]
        == "line 1: import subprocess (an import of subprocess that program() does not use)"
    )
    assert cleaned.dropped[1].startswith("line 6: for i in range(3): (top-level demo code)")


def test_the_last_program_wins_and_redefined_api_names_go() -> None:
    source = (
        "def program(input_scene):\n    return 'draft'\n\n"
        "pySpatial = None\nnp = object()\n\n"
        "def program(input_scene):\n    recon = pySpatial.reconstruct(input_scene)\n"
        "    return pySpatial.describe_camera_motion(recon)\n"
    )
    cleaned = clean_program(source)
    assert "draft" not in cleaned.source and "pySpatial = None" not in cleaned.source
    assert "an earlier def program" in cleaned.dropped[0]
    assert "stand-in for pySpatial" in cleaned.dropped[1] and "stand-in for np" in cleaned.dropped[2]
    validate_program(cleaned.source)


def test_statements_sharing_a_line_are_rebuilt_from_the_tree() -> None:
    cleaned = clean_program("X = 2; print(X)\n" + "def program(input_scene):\n    return X\n")
    assert cleaned.source == "X = 2\n\ndef program(input_scene):\n    return X\n"
    validate_program(cleaned.source)


@pytest.mark.parametrize("source", ["def program(:\n", "x = 1\n", ""])
def test_source_without_a_parseable_program_is_left_for_the_validator(source: str) -> None:
    assert clean_program(source).source == source and clean_program(source).dropped == []


def test_fingerprints_ignore_comments_and_layout() -> None:
    a = "def program(input_scene):\n    # look back\n    return 1\n"
    b = "def program(input_scene):\n\n    return 1   # same\n"
    assert program_fingerprint(a) == program_fingerprint(b)
    assert program_fingerprint(a) != program_fingerprint(a.replace("1", "2"))
