"""The paraphrase corpus: deterministic, split by whole wordings, expected readings consistent; the
templeRing MMSI-schema generator read back by evaluation/mmsi.py's reader."""

from __future__ import annotations

import random
import re

import pytest

from tests.support.paraphrases import (
    SPLIT_SEED,
    SPLITS,
    AskSpec,
    ClaimSpec,
    load_wordings,
    phrase,
    split_lists,
    text_corpus,
)


def _ids(wordings: dict[str, list[dict]]) -> set[str]:
    return {entry["id"] for entries in wordings.values() for entry in entries}


def test_the_corpus_is_the_same_every_time_and_differs_by_seed():
    first = [item.as_json() for item in text_corpus("tuning", 80, seed=3)]
    assert first == [item.as_json() for item in text_corpus("tuning", 80, seed=3)]
    assert first != [item.as_json() for item in text_corpus("tuning", 80, seed=4)]


def test_the_committed_split_is_the_seeded_split_of_the_whole_lists():
    tuning, heldout = load_wordings("tuning"), load_wordings("heldout")
    assert not _ids(tuning) & _ids(heldout)
    whole = {}
    for name in tuning:
        entries = sorted(tuning[name] + heldout[name], key=lambda e: e["id"])
        assert [e["id"] for e in entries] == [f"{name}.{i:02d}" for i in range(len(entries))]
        whole[name] = [e["text"] for e in entries]
        assert tuning[name] and heldout[name], f"{name}: each side needs a wording"
    assert split_lists(whole, SPLIT_SEED) == (tuning, heldout)


def _option_texts(wordings: dict[str, list[dict]]) -> set[str]:
    return {
        text
        for name, entries in wordings.items()
        if name.startswith("option.")
        for e in entries
        for text in e["text"].values()
    }


@pytest.mark.parametrize("split", SPLITS)
def test_an_item_uses_only_its_own_side_s_wordings(split):
    other = "heldout" if split == "tuning" else "tuning"
    own, foreign = _ids(load_wordings(split)), _option_texts(load_wordings(other))
    for item in text_corpus(split, 300, seed=1):
        assert set(item.wording_ids) <= own
        options = re.split(r"\n[A-D]\. |\nOptions: A: |, [B-D]: ", item.text)[1:]
        assert options and not set(options) & foreign, item.text


def _names(item_text: str, view: int) -> bool:
    words = {1: "one|first|1st", 2: "two|second|2nd", 3: "three|third|3rd", 4: "four|fourth|4th"}[view]
    return re.search(rf"(?<![\w.]){view}\b|\b(?:{words})\b|\b(?:last|final)\b", item_text) is not None


def test_every_expected_pair_is_named_in_the_text_and_abstaining_items_say_why():
    for item in text_corpus("tuning", 400, seed=2):
        if item.abstain == "pair":
            assert item.views is None and item.image_count >= 3
        elif item.abstain == "option":
            assert list(item.options.values()).count({"kind": "two claims"}) == 1 and " or " in item.text
        elif item.abstain == "quantity":
            assert item.quantity is None
        elif item.views != (1, 2) or item.image_count != 2:  # with two images the pair may go unnamed
            assert all(_names(item.text, view) for view in item.views), item.text


def _plain_references(split: str) -> dict[str, list[dict]]:
    """The split's lists with one way to name a view ("image N") and no notes."""
    wordings = dict(load_wordings(split))
    wordings["noun"] = [{"id": "noun.test", "text": "image"}]
    wordings["reference"] = [{"id": "reference.test", "text": "{noun} {n}"}]
    return wordings


@pytest.mark.parametrize("split", SPLITS)
def test_swapping_the_views_swaps_the_expected_pair_and_nothing_else(split):
    claims = (ClaimSpec("translation", ("left",)), ClaimSpec("translation", ("up",)))
    claims += (ClaimSpec("still"), ClaimSpec("translation", ("forward",)))
    wordings = _plain_references(split)
    for seed in range(40):
        one = phrase(AskSpec(3, (1, 3), "translation", claims, 0), wordings, split, "x", random.Random(seed))
        other = phrase(
            AskSpec(3, (3, 1), "translation", claims, 0), wordings, split, "x", random.Random(seed)
        )
        assert (one.views, other.views) == ((1, 3), (3, 1))
        swapped = re.sub(r"(?i)(image) ([13])", lambda m: f"{m[1]} {4 - int(m[2])}", one.text)
        assert swapped == other.text
        assert one.options == other.options and one.quantity == other.quantity == "translation"


def test_options_of_mixed_kinds_ask_motion_and_still_asks_nothing_of_its_own():
    from tests.support.paraphrases import quantity_of

    turn = ClaimSpec("rotation", axis="yaw", sense="left")
    step = ClaimSpec("translation", ("left",))
    assert quantity_of((turn, step)) == "motion"
    assert quantity_of((turn, ClaimSpec("still"))) == "rotation"
    assert quantity_of((step, ClaimSpec("still"))) == "translation"


def test_a_templering_option_set_has_exactly_one_true_option():
    from bench.templering_questions import claims_for

    words = {
        "lateral": "left",
        "depth": "forward",
        "vertical": "none",
        "turn": "none",
        "tilt": "up",
        "roll": "none",
    }
    for seed in range(30):
        for quantity in ("translation", "position", "rotation"):
            claims, truth = claims_for(words, quantity, random.Random(seed))
            holding = [c for c in claims if _holds(c, words)]
            assert holding == [claims[truth]]
    assert claims_for({**words, "turn": "none", "tilt": "none"}, "rotation", random.Random(0)) is None


def _holds(claim: ClaimSpec, words: dict[str, str]) -> bool:
    if claim.kind == "still":
        return False
    if claim.kind == "rotation":
        return words[{"yaw": "turn", "pitch": "tilt", "roll": "roll"}[claim.axis]] == claim.sense
    return claim.ways[0] in words.values() and any(
        words[a] == claim.ways[0] for a in ("lateral", "depth", "vertical")
    )


def test_the_templering_mmsi_parquet_reads_back_with_the_mmsi_reader(tmp_path):
    from bench.templering_data import realdata_dir

    assert realdata_dir() is not None, "templeRing not found: ../shared/realdata or PYSPATIAL_REALDATA_DIR"
    from bench.mmsi_templering import mmsi_rows, question_specs
    from evaluation.mmsi import REQUIRED_COLUMNS, read_mmsi, rotated_question
    from shared.synthetic.mmsi import CAM_CAM, MOTION_CAM, write_parquet

    specs = question_specs()
    assert len(specs) == 41
    kinds = [spec.quantity for _, spec, _ in specs]
    assert kinds.count("position") == 12
    read = {}
    for split in SPLITS:
        rows = mmsi_rows(split, limit=3)
        assert set(REQUIRED_COLUMNS) <= set(rows[0])
        write_parquet(rows, tmp_path / f"{split}.parquet")
        read[split] = read_mmsi(tmp_path / f"{split}.parquet", tmp_path / split)
    for tuning, heldout, (photo_set, spec, _) in zip(read["tuning"], read["heldout"], specs, strict=False):
        assert tuning.id == heldout.id and tuning.gt_answer == heldout.gt_answer
        assert tuning.question != heldout.question
        assert tuning.question_type == (CAM_CAM if spec.quantity == "position" else MOTION_CAM)
        assert len(tuning.images) == len(photo_set.images) and all(
            p.stat().st_size > 0 for p in tuning.images
        )
        _, options = rotated_question(tuning.question, 0)
        assert list(options) == ["A", "B", "C", "D"]
