"""Turn a program's return value into the visual clue: text plus image handles (child side).

Accepted: str, int, float, bool, None, an Image, numpy arrays and scalars, and lists / tuples /
dicts of those nested at most `MAX_DEPTH` deep. Text rendering:
- a str is the text itself; a number, bool or None is its `str`;
- an Image is an image and no text;
- a list / tuple puts one item per line and a dict one `key: value` per line; images inside become
  `<image k>` placeholders (k counts from 1 in clue order); deeper containers are JSON.
A value made only of images has no text.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from services.agent.sandbox.api import Image

MAX_DEPTH = 3
MAX_ARRAY_ITEMS = 10_000
MAX_CONTAINER_ITEMS = 10_000


class OutputRejected(ValueError):
    """The return value cannot become a clue; the message says why, for the code model."""


class OutputTooLarge(OutputRejected):
    """The return value is a valid clue but exceeds a size limit."""


@dataclass
class RenderedOutput:
    text: str | None
    image_ids: list[str] = field(default_factory=list)


class _Renderer:
    def __init__(self) -> None:
        self.image_ids: list[str] = []
        self.items_seen = 0

    def placeholder(self, image: Image) -> str:
        if image.id not in self.image_ids:
            self.image_ids.append(image.id)
        return f"<image {self.image_ids.index(image.id) + 1}>"

    def plain(self, value: Any, depth: int) -> Any:
        """A JSON-able copy of `value` with images as placeholders."""
        self.items_seen += 1
        if self.items_seen > MAX_CONTAINER_ITEMS:
            raise OutputTooLarge(f"the return value has more than {MAX_CONTAINER_ITEMS} items")
        if value is None or isinstance(value, bool | str):
            return value
        if isinstance(value, int | float | np.number | np.bool_):
            return _scalar(value)
        if isinstance(value, Image):
            return self.placeholder(value)
        if isinstance(value, np.ndarray):
            return _array(value)
        if isinstance(value, list | tuple | dict):
            if depth >= MAX_DEPTH:
                raise OutputRejected(f"the return value is nested more than {MAX_DEPTH} levels deep")
            if isinstance(value, dict):
                return {_key(key): self.plain(item, depth + 1) for key, item in value.items()}
            return [self.plain(item, depth + 1) for item in value]
        raise OutputRejected(_unsupported(value))

    def line(self, value: Any) -> str:
        plain = self.plain(value, depth=1)
        if isinstance(plain, str):
            return plain
        if isinstance(plain, list | dict):
            return json.dumps(plain, ensure_ascii=False)
        return str(plain)


def render_output(value: Any, max_chars: int, max_images: int) -> RenderedOutput:
    """Render a program's return value; raise OutputRejected when it is not a valid clue."""
    renderer = _Renderer()
    if isinstance(value, Image):
        lines: list[str] = []
        renderer.placeholder(value)
    elif isinstance(value, list | tuple):
        lines = [renderer.line(item) for item in value]
    elif isinstance(value, dict):
        lines = [f"{_key(key)}: {renderer.line(item)}" for key, item in value.items()]
    else:
        lines = [renderer.line(value)]
    if len(renderer.image_ids) > max_images:
        raise OutputTooLarge(
            f"the program returned {len(renderer.image_ids)} images; at most {max_images} are allowed"
        )
    placeholders = {f"<image {k}>" for k in range(1, len(renderer.image_ids) + 1)}
    only_images = bool(renderer.image_ids) and all(line in placeholders for line in lines)
    text = None if only_images else "\n".join(lines)
    if text is not None and len(text) > max_chars:
        raise OutputTooLarge(
            f"the output is {len(text)} characters long; the limit is {max_chars}: return a shorter summary"
        )
    return RenderedOutput(text=text, image_ids=renderer.image_ids)


def _scalar(value: Any) -> int | float | bool:
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, int):
        return int(value)  # bool subclasses are handled before, int subclasses become plain ints
    return float(value)  # NaN and inf are kept: the text shows NaN / Infinity


def _array(array: np.ndarray) -> Any:
    if array.dtype == object or array.dtype.kind not in "biuf":
        raise OutputRejected(f"numpy arrays of dtype {array.dtype} cannot be returned; return numbers")
    if array.size > MAX_ARRAY_ITEMS:
        raise OutputTooLarge(
            f"a returned numpy array has {array.size} items; the limit is {MAX_ARRAY_ITEMS}: return a summary"
        )
    return array.tolist()


def _key(key: Any) -> str:
    if isinstance(key, str):
        return key
    if isinstance(key, bool | int | float | np.number) or key is None:
        return "None" if key is None else str(_scalar(key))
    if isinstance(key, tuple) and all(isinstance(k, str | int | float) for k in key):
        return str(key)
    raise OutputRejected(f"dict keys must be strings or numbers, not {type(key).__name__}")


def _unsupported(value: Any) -> str:
    kind = type(value).__name__
    if isinstance(value, set | frozenset):
        return f"the program returned a {kind}; return a list instead"
    return (
        f"a value of type {kind} cannot be returned; return a str, a number, an image, "
        "or a list / dict of those"
    )
