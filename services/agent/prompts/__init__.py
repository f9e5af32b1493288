"""Versioned prompt templates: `<name>_v<N>.md` files beside this module.

A template holds `{{field}}` placeholders. `render` fills them all (a missing or unexpected field is
an error, so a prompt never goes out half-filled); `render_parts` also lets some placeholders be
"slots" that take a list of chat content parts (images), giving the interleaved text/image content
of one chat message. In-context examples for the code prompt live in `<name>_examples_v<N>.md`:
sections that start with "## Example: <title>", each a question and one ```python block.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Any

from pydantic import BaseModel

PROMPT_DIR = Path(__file__).resolve().parent
_PLACEHOLDER = re.compile(r"\{\{\s*([a-z_][a-z0-9_]*)\s*\}\}")
_VERSIONED = re.compile(r"^(?P<name>[a-z_]+?)_v(?P<version>\d+)$")


class PromptError(ValueError):
    """A template or example file is missing or malformed, or fields do not match its placeholders."""


class PromptTemplate(BaseModel, frozen=True):
    name: str
    version: int
    text: str

    @property
    def id(self) -> str:
        return f"{self.name}_v{self.version}"

    @property
    def fields(self) -> frozenset[str]:
        return frozenset(_PLACEHOLDER.findall(self.text))

    def _check(self, given: set[str]) -> None:
        missing = self.fields - given
        unexpected = given - self.fields
        if missing or unexpected:
            raise PromptError(
                f"template {self.id}: missing fields {sorted(missing)}, "
                f"unexpected fields {sorted(unexpected)}"
            )

    def render(self, **fields: object) -> str:
        """The template with every placeholder replaced by str(value)."""
        self._check(set(fields))
        return _PLACEHOLDER.sub(lambda match: str(fields[match.group(1)]), self.text)

    def render_parts(self, slots: dict[str, list[dict[str, Any]]], **fields: object) -> list[dict[str, Any]]:
        """Chat content parts: text between slots, and each slot's parts where its placeholder stands."""
        self._check(set(fields) | set(slots))
        parts: list[dict[str, Any]] = []
        position = 0
        for match in _PLACEHOLDER.finditer(self.text):
            name = match.group(1)
            if name not in slots:
                continue
            _append_text(parts, self._fill(self.text[position : match.start()], fields))
            parts.extend(slots[name])
            position = match.end()
        _append_text(parts, self._fill(self.text[position:], fields))
        return parts

    @staticmethod
    def _fill(text: str, fields: dict[str, object]) -> str:
        return _PLACEHOLDER.sub(lambda match: str(fields[match.group(1)]), text)


def _append_text(parts: list[dict[str, Any]], text: str) -> None:
    text = text.strip("\n")
    if text.strip():
        parts.append({"type": "text", "text": text})


class PromptExample(BaseModel, frozen=True):
    title: str
    question: str
    code: str


def available_versions(name: str) -> list[int]:
    versions = []
    for path in PROMPT_DIR.glob(f"{name}_v*.md"):
        match = _VERSIONED.match(path.stem)
        if match and match.group("name") == name:
            versions.append(int(match.group("version")))
    return sorted(versions)


def _resolve(name: str) -> tuple[str, int]:
    """("codegen_v1" | "codegen") -> ("codegen", 1); a bare name means its latest version."""
    match = _VERSIONED.match(name)
    if match:
        return match.group("name"), int(match.group("version"))
    versions = available_versions(name)
    if not versions:
        raise PromptError(f"no prompt template named {name!r} in {PROMPT_DIR}")
    return name, versions[-1]


@lru_cache(maxsize=32)
def load_template(name: str) -> PromptTemplate:
    """A template by name ("answer" = latest version) or by exact id ("answer_v1")."""
    base, version = _resolve(name)
    path = PROMPT_DIR / f"{base}_v{version}.md"
    if not path.is_file():
        raise PromptError(f"no prompt template {path.name} in {PROMPT_DIR}")
    return PromptTemplate(name=base, version=version, text=path.read_text(encoding="utf-8"))


_EXAMPLE_HEADING = re.compile(r"^## Example:\s*(.+)$", re.MULTILINE)
_CODE_BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)


@lru_cache(maxsize=8)
def load_examples(name: str) -> tuple[PromptExample, ...]:
    """In-context examples from `<name>.md`, e.g. "codegen_examples_v1" (a bare name means its
    latest version), in file order."""
    base, version = _resolve(name)
    path = PROMPT_DIR / f"{base}_v{version}.md"
    if not path.is_file():
        raise PromptError(f"no example file {path.name} in {PROMPT_DIR}")
    text = path.read_text(encoding="utf-8")
    headings = list(_EXAMPLE_HEADING.finditer(text))
    examples = []
    for index, heading in enumerate(headings):
        end = headings[index + 1].start() if index + 1 < len(headings) else len(text)
        body = text[heading.end() : end]
        code = _CODE_BLOCK.search(body)
        if code is None or "Question:" not in body[: code.start()]:
            raise PromptError(
                f"{path.name}: example {heading.group(1)!r} needs a 'Question:' and a python block"
            )
        question = body[: code.start()].split("Question:", 1)[1]
        examples.append(
            PromptExample(
                title=heading.group(1).strip(), question=" ".join(question.split()), code=code.group(1)
            )
        )
    return tuple(examples)


__all__ = [
    "PROMPT_DIR",
    "PromptError",
    "PromptExample",
    "PromptTemplate",
    "available_versions",
    "load_examples",
    "load_template",
]
