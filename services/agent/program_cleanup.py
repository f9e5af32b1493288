"""Keep what a code model meant: `program`, its helpers, constants and imports; drop the demo code.

Real code models wrap a sound `def program(input_scene)` in script scaffolding: a stub
`class Scene`, `input_scene = Scene()`, `print(program(input_scene))`, `if __name__ == "__main__":`,
`import pySpatial`. The validator rightly refuses such top-level code, and the model, told so, rarely
manages to remove it. This step runs before validation and removes it, recording every line it
dropped, so the program the model meant is the one that is checked and run.

What stays: `def program`, and every top-level function, constant, import or other binding that
`program` reaches by name (transitively), plus `import numpy as np` / `import math` (the sandbox
binds those). What goes: everything `program` does not reach (demo calls, prints, `if __name__`,
stub classes, stand-in scenes), bindings of the names the sandbox provides (`pySpatial`, `np`,
`math`, `input_scene`, `Scene`, ...) and earlier duplicate definitions of `program`. Nothing unsafe
is made safe here: whatever stays is still checked by the validator, which alone decides what runs.
"""

from __future__ import annotations

import ast
import hashlib
from dataclasses import dataclass, field

# What ast.parse raises on hostile text: SystemError too, which CPython 3.11 raises on deep nesting
# ("AST constructor recursion depth mismatch") where RecursionError would be expected.
UNPARSABLE_ERRORS = (SyntaxError, ValueError, RecursionError, MemoryError, SystemError)

PROGRAM_NAME = "program"
# Names the sandbox binds: a program's own definition of one is a stand-in, never the real thing.
PROVIDED_NAMES = frozenset(
    {"pySpatial", "np", "numpy", "math", "input_scene", "Scene", "Reconstruction", "Image", "ToolError"}
)
# Modules whose import the sandbox accepts (it binds a restricted stand-in under the name).
SANDBOX_MODULES = frozenset({"numpy", "math"})
_SHOWN_CHARS = 70


@dataclass(frozen=True)
class CleanedProgram:
    source: str
    dropped: list[str] = field(default_factory=list)  # "line N: <code> (<why>)", in source order


def _first_line(node: ast.stmt) -> int:
    decorators = getattr(node, "decorator_list", None) or []
    return min([node.lineno, *(decorator.lineno for decorator in decorators)])


def _bound_names(node: ast.stmt) -> set[str]:
    """Module-level names a statement binds (functions, classes, assignments, imports)."""
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
        return {node.name}
    if isinstance(node, ast.Import | ast.ImportFrom):
        return {(alias.asname or alias.name).split(".")[0] for alias in node.names}
    targets: list[ast.expr] = []
    if isinstance(node, ast.Assign):
        targets = node.targets
    elif isinstance(node, ast.AnnAssign | ast.AugAssign):
        targets = [node.target]
    names: set[str] = set()
    for target in targets:
        if isinstance(target, ast.Name):
            names.add(target.id)
        elif isinstance(target, ast.Tuple | ast.List):
            names.update(element.id for element in target.elts if isinstance(element, ast.Name))
    return names


def _used_names(node: ast.AST) -> set[str]:
    return {child.id for child in ast.walk(node) if isinstance(child, ast.Name)}


def _is_sandbox_import(node: ast.stmt) -> bool:
    if isinstance(node, ast.Import):
        return all(alias.name.split(".")[0] in SANDBOX_MODULES for alias in node.names)
    if isinstance(node, ast.ImportFrom):
        return (node.module or "").split(".")[0] in SANDBOX_MODULES and not node.level
    return False


def _is_docstring(index: int, node: ast.stmt) -> bool:
    return (
        index == 0
        and isinstance(node, ast.Expr)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
    )


def _why_dropped(node: ast.stmt, bound: set[str]) -> str:
    if isinstance(node, ast.Import | ast.ImportFrom):
        module = node.module if isinstance(node, ast.ImportFrom) else node.names[0].name
        if bound & PROVIDED_NAMES:
            return f"an import of {module}; the sandbox provides {', '.join(sorted(bound & PROVIDED_NAMES))}"
        return f"an import of {module} that program() does not use"
    if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        bases = {
            target.value.id
            for target in targets
            if isinstance(target, ast.Attribute | ast.Subscript) and isinstance(target.value, ast.Name)
        }
        bound = bound | (bases & PROVIDED_NAMES)
    if bound & PROVIDED_NAMES:
        provided = ", ".join(sorted(bound & PROVIDED_NAMES))
        return f"a stand-in for {provided}, which the sandbox provides"
    if isinstance(node, ast.If) and "__name__" in _used_names(node.test):
        return "script entry point"
    if isinstance(node, ast.Expr):
        call = node.value
        if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "print":
            return "demo output; program() returns its clue"
        return "top-level demo code"
    if isinstance(node, ast.ClassDef):
        return "a class program() does not use"
    if bound:
        return "top-level code program() does not use"
    return "top-level demo code"


def _describe(node: ast.stmt, lines: list[str], why: str) -> str:
    first = _first_line(node)
    text = lines[first - 1].strip() if 0 < first <= len(lines) else ""
    if len(text) > _SHOWN_CHARS:
        text = text[: _SHOWN_CHARS - 3] + "..."
    return f"line {first}: {text} ({why})"


def clean_program(source: str) -> CleanedProgram:
    """`source` without top-level code that `program` does not use; see the module docstring.

    Source that does not parse, or has no `def program`, is returned as it is: the validator
    then says what is wrong with it.
    """
    try:
        tree = ast.parse(source)
    except UNPARSABLE_ERRORS:
        return CleanedProgram(source)
    body = tree.body
    programs = [
        i for i, node in enumerate(body) if isinstance(node, ast.FunctionDef) and node.name == PROGRAM_NAME
    ]
    if not programs:
        return CleanedProgram(source)
    keep: set[int] = {programs[-1]}
    bindings: dict[str, list[int]] = {}
    for index, node in enumerate(body):
        for name in _bound_names(node):
            if name not in PROVIDED_NAMES and name != PROGRAM_NAME:
                bindings.setdefault(name, []).append(index)
    pending = list(_used_names(body[programs[-1]]))
    seen: set[str] = set()
    while pending:  # everything program() reaches by name, transitively
        name = pending.pop()
        if name in seen:
            continue
        seen.add(name)
        for index in bindings.get(name, []):
            if index not in keep:
                keep.add(index)
                pending.extend(_used_names(body[index]))
    for index, node in enumerate(body):
        if _is_docstring(index, node) or _is_sandbox_import(node):
            keep.add(index)
    lines = source.splitlines()
    dropped_nodes = [(index, node) for index, node in enumerate(body) if index not in keep]
    if not dropped_nodes:
        return CleanedProgram(source)
    dropped = []
    for _, node in dropped_nodes:
        if isinstance(node, ast.FunctionDef) and node.name == PROGRAM_NAME:
            why = f"an earlier def {PROGRAM_NAME}; the last one is kept"
        else:
            why = _why_dropped(node, _bound_names(node))
        dropped.append(_describe(node, lines, why))
    return CleanedProgram(_without(source, lines, body, keep), dropped)


def _without(source: str, lines: list[str], body: list[ast.stmt], keep: set[int]) -> str:
    """The kept statements with their own text (comments included) where lines are not shared."""
    kept_lines: set[int] = set()
    dropped_lines: set[int] = set()
    for index, node in enumerate(body):
        span = set(range(_first_line(node), (node.end_lineno or node.lineno) + 1))
        (kept_lines if index in keep else dropped_lines).update(span)
    if kept_lines & dropped_lines:  # `x = 1; print(x)`: statements share a line, rebuild from the tree
        module = ast.Module(body=[node for index, node in enumerate(body) if index in keep], type_ignores=[])
        return ast.unparse(module) + "\n"
    last_kept = max(kept_lines)
    text = "\n".join(
        line
        for number, line in enumerate(lines, start=1)
        # after the last kept statement only dropped code and its comments ("# Example usage") remain
        if number not in dropped_lines and (number <= last_kept or not _is_comment_or_blank(line))
    )
    return text.strip("\n") + "\n"


def _is_comment_or_blank(line: str) -> bool:
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def program_fingerprint(source: str) -> str:
    """Equal for programs that differ only in comments, blank lines or formatting."""
    try:
        canonical = ast.dump(ast.parse(source))
    except UNPARSABLE_ERRORS:
        canonical = "\n".join(line.strip() for line in source.splitlines() if line.strip())
    return hashlib.sha256(canonical.encode("utf-8", "surrogatepass")).hexdigest()


__all__ = ["CleanedProgram", "clean_program", "program_fingerprint"]
