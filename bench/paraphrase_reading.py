"""Camera questions in many wordings: is each read right (pair, quantity, every option's claim)?

    python -m bench paraphrase_reading [--count 600] [--seed 0] [--split tuning|heldout|both]

Pure text. The items come from the paraphrase corpus (tests/support/paraphrases.py), its tuning
and held-out wordings reported apart. Per split: the pair read right, the quantity, every option's
claim, all three at once; the items that must abstain (ambiguous pair, an option that says two
things, stem and options disagreeing) abstained; and the pairs read wrong with certainty (the
reading that would let a misread pair answer). `--failures N` prints N misread tuning items
(held-out failures are only counted, so no change is fitted to them).
"""

from __future__ import annotations

import argparse
from collections import Counter

from shared.questions.claims import is_read
from shared.questions.reading import QuestionReading, read_question
from tests.support.paraphrases import SPLITS, ParaphraseItem, text_corpus


def claim_dict(claim, quantity: str) -> dict:
    """A read claim in the corpus's plain form. A bare direction is as the reading left it: the
    reading gives it the kind the stem asks when the stem says it, and leaves it bare (so the
    question abstains) when not. A step and a position are the same geometry (issue 34: the second
    camera's centre in the first camera's frame): in a position question a step claim counts as the
    position, and in a translation question a position claim ("It stood higher") as the step."""
    data = claim.model_dump(exclude={"source", "why", "degrees"})
    if "ways" in data:
        data["ways"] = list(data["ways"])
    if quantity == "position" and data["kind"] == "translation":
        data["kind"] = "position"
    if quantity == "translation" and data["kind"] == "position":
        data["kind"] = "translation"
    return data


def judge(item: ParaphraseItem, reading: QuestionReading) -> dict[str, bool]:
    """Per slot whether the reading is what the item expects."""
    if item.abstain is not None:
        return {"abstained": reading.abstain_reason is not None}
    options = {
        letter: claim_dict(reading.options[letter], reading.quantity) if letter in reading.options else None
        for letter in item.options
    }
    verdict = {
        "pair": reading.views == item.views,
        "quantity": reading.quantity == item.quantity,
        "options": options == item.options,
        "not abstained": reading.abstain_reason is None,
    }
    verdict["all"] = all(verdict.values())
    verdict["misread pair, certain"] = not verdict["pair"] and reading.views_certain
    return verdict


def option_outcomes(item: ParaphraseItem, reading: QuestionReading) -> list[str]:
    """Per expected option: "option right", "option unread" (no claim, or a bare direction the
    question gives no kind), or "option misread" (read as another claim: the failure that can answer
    wrong)."""
    outcomes = []
    for letter, expected in item.options.items():
        claim = reading.options.get(letter)
        if claim is None or not is_read(claim):
            outcomes.append("option unread")
        elif _geometry(claim_dict(claim, reading.quantity)) == _geometry(expected):
            outcomes.append("option right")
        else:
            outcomes.append("option misread")
    return outcomes


def _geometry(claim: dict) -> dict:
    """A claim with a step and a position taken as the same geometry (what the matcher compares)."""
    return {**claim, "kind": "step"} if claim.get("kind") in ("translation", "position") else claim


def measure(
    items: list[ParaphraseItem],
) -> tuple[Counter, list[tuple[ParaphraseItem, QuestionReading, dict]]]:
    counts: Counter = Counter()
    failures = []
    for item in items:
        reading = read_question(item.text, item.image_count)
        verdict = judge(item, reading)
        counts["abstain items" if item.abstain else "items"] += 1
        counts.update(name for name, ok in verdict.items() if ok)
        if item.abstain is None:
            counts.update(option_outcomes(item, reading))
        if not verdict.get("all", verdict.get("abstained")):
            failures.append((item, reading, verdict))
    return counts, failures


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench paraphrase_reading", description=__doc__)
    parser.add_argument("--count", type=int, default=600)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--split", choices=(*SPLITS, "both"), default="both")
    parser.add_argument("--failures", type=int, default=0, help="print this many misread tuning items")
    args = parser.parse_args(argv)
    splits = SPLITS if args.split == "both" else (args.split,)
    print(
        "| split | items | pair right | quantity right | every option right | all right | "
        "pair misread with certainty | must abstain | abstained |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    shown = []
    for split in splits:
        counts, failures = measure(text_corpus(split, args.count, args.seed))
        n = counts["items"]
        cells = [
            f"{counts[k]} ({100 * counts[k] / max(n, 1):.1f}%)"
            for k in ("pair", "quantity", "options", "all")
        ]
        print(
            f"| {split} | {n} | " + " | ".join(cells) + f" | {counts['misread pair, certain']} | "
            f"{counts['abstain items']} | {counts['abstained']} |"
        )
        print(
            f"|   options of {split}: {counts['option right']} right, {counts['option unread']} unread, "
            f"{counts['option misread']} read as another claim |"
        )
        if split == "tuning":
            shown = failures[: args.failures]
    for item, reading, verdict in shown:
        wrong = [name for name, ok in verdict.items() if not ok and name != "misread pair, certain"]
        print(f"\n{item.id} wrong: {', '.join(wrong)}\n{item.text}")
        print(f"expected views {item.views} quantity {item.quantity} abstain {item.abstain}")
        print(f"read {reading.summary!r} views {reading.views} quantity {reading.quantity}")
        print(f"abstain: {reading.abstain_reason}")
        for letter, claim in item.options.items():
            got = reading.options.get(letter)
            print(f"  {letter}: expected {claim} read {got.model_dump(exclude={'source'}) if got else None}")


if __name__ == "__main__":
    main()
