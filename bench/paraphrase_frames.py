"""Which frame each camera question is read in: the start view's (stated or by default), another
view's, the room, an object, or axes named in words not read (the answer is then refused).

    python -m bench paraphrase_frames [--count 600] [--seeds 0,3]

Pure text, over the paraphrase corpus (tests/support/paraphrases.py), tuning and held-out wordings
counted apart. Every frame note of the corpus names the start view, so a reading in any other frame
is a misreading, and "axes in words not read" is a refusal where an answer was possible. Held-out
items are only counted.
"""

from __future__ import annotations

import argparse
from collections import Counter

from shared.questions.reading import QuestionReading, read_question
from tests.support.paraphrases import SPLITS, text_corpus


def frame_outcome(reading: QuestionReading, start: int) -> str:
    frame = reading.frame
    if frame is None:
        return "no frame"
    if not reading.frame_certain and reading.frame_source:
        return "axes in words not read"
    if frame.kind != "view_axes":
        return frame.kind
    if frame.view != start:
        return "another view"
    return "start view (stated)" if reading.frame_certain else "start view (default)"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pyspatial bench paraphrase_frames", description=__doc__)
    parser.add_argument("--count", type=int, default=600)
    parser.add_argument("--seeds", default="0,3")
    args = parser.parse_args(argv)
    for split in SPLITS:
        outcomes: Counter[str] = Counter()
        for seed in (int(s) for s in args.seeds.split(",")):
            for item in text_corpus(split, args.count, seed=seed):
                if item.views is not None:  # items that must abstain on the pair have no frame to judge
                    outcomes[frame_outcome(read_question(item.text, item.image_count), item.views[0])] += 1
        print(f"{split}: " + ", ".join(f"{name} {count}" for name, count in sorted(outcomes.items())))


if __name__ == "__main__":
    main()
