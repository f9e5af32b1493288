"""The recorded replies of a real code model (tests/data/model_replies), as typed records."""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

REPLIES_DIR = Path(__file__).resolve().parents[1] / "data" / "model_replies"
QWEN_CODER_1_5B = REPLIES_DIR / "qwen2.5-coder-1.5b-instruct-q4.jsonl"


@dataclass(frozen=True)
class RecordedReply:
    index: int  # line number in the file, from 0
    question_id: str
    attempt: int
    finish_reason: str
    usage: dict[str, int]
    reply: str
    feedback: str | None  # the repair message that prompted this attempt

    @property
    def name(self) -> str:
        return f"{self.index:02d}-{self.question_id}-attempt{self.attempt}"

    def script_entry(self) -> dict:
        """The reply as the scripted server replays it, with the real finish reason and usage."""
        return {"text": self.reply, "finish_reason": self.finish_reason, "usage": self.usage}


@lru_cache(maxsize=4)
def recorded_replies(path: Path = QWEN_CODER_1_5B) -> tuple[RecordedReply, ...]:
    rows = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
    return tuple(
        RecordedReply(
            index=index,
            question_id=row["id"],
            attempt=int(row["attempt"]),
            finish_reason=row["finish_reason"],
            usage=row["usage"],
            reply=row["reply"],
            feedback=row["feedback_that_prompted_this_attempt"],
        )
        for index, row in enumerate(rows)
    )
