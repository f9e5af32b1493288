"""The clue of the program that ran: what the answerer reads, and what the response shows."""

from __future__ import annotations

import base64
import io
from dataclasses import dataclass, field

import numpy as np
from PIL import Image

from services.agent.clue_views import clue_views
from services.agent.evidence import typed_in_lines
from services.agent.recon_tools import ReconToolProvider
from services.agent.stages.program import WrittenProgram
from shared.questions.intent import QuestionIntent
from shared.wire.schemas import CameraInfo, Clue

EMPTY_VIEW_COVERAGE = 0.05  # a rendered view with less of its area drawn than this "shows nothing"


def coverage_notes(clue_images: list[bytes]) -> list[str]:
    """Say which rendered views are (nearly) empty.

    Novel views are rendered on white; where the reconstruction has no points (a direction no
    input photo looked at) the view stays blank. Saying so keeps an answer model from reading
    meaning into an empty picture.
    """
    notes = []
    for index, png in enumerate(clue_images, start=1):
        rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
        drawn = float(np.mean(np.any(rgb != 255, axis=2)))
        if drawn < EMPTY_VIEW_COVERAGE:
            notes.append(
                f"Rendered view {index} shows almost nothing ({drawn:.0%} of it drawn): that direction "
                "was not seen in the input images, so the reconstruction has no points there."
            )
    return notes


@dataclass
class ClueReading:
    clue: Clue = field(default_factory=Clue)  # for the response: the program's output as it came
    text: str | None = None  # for the answerer: typed-in lines of a model's program left out
    notes: list[str] = field(default_factory=list)


def read_clue(
    written: WrittenProgram, intent: QuestionIntent, tools: ReconToolProvider, cameras: list[CameraInfo]
) -> ClueReading:
    """The clue of `written.run` (a successful run) with notes on empty views and typed-in lines."""
    run, program = written.run, written.program
    if run is None or program is None:
        return ClueReading()
    notes = coverage_notes(run.clue_pngs)
    text = run.clue_text
    if written.by_model:  # evidence, not assertions (services/agent/evidence.py)
        text, typed = typed_in_lines(text, program, intent)
        notes = [*notes, *typed]
    clue = Clue(
        text=run.clue_text,
        images=[base64.b64encode(png).decode("ascii") for png in run.clue_pngs],
        views=clue_views(run.clue_pngs, tools, cameras),
        notes=notes,
    )
    return ClueReading(clue, text, notes)


__all__ = ["ClueReading", "coverage_notes", "read_clue"]
