"""The project's import graph, read with `ast`, and the layering rules it must keep.

Every `import` and `from ... import` counts wherever it stands: at module level, inside a
function, under `if TYPE_CHECKING:`. Only the project's own modules are nodes; third-party and
standard-library imports are left out. A tree is a mapping {module name: source text}, so a test
can check an overlay of the real tree with one import written into it.

The rules (docs/ARCHITECTURE.md, "Layout"):
- `shared` imports nothing from `services`, `cli`, `evaluation`, `bench` or `tests`;
- inside `shared` each layer imports only itself and the layers below it (`SHARED_LAYERS`);
- `services.recon` and `services.agent` never import each other;
- the sandbox worker (`services.agent.sandbox.worker` and all it imports, its packages' `__init__`
  modules included, since the jailed process runs them) imports only `services.agent.sandbox` and
  `shared`: nothing of the agent's app layer, which the jail does not even mount;
- inside each service no import cycle: every strongly connected component is a single module.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterable, Mapping
from pathlib import Path

PACKAGES = ("shared", "services", "cli", "evaluation", "bench", "tests")
SHARED_OUTSIDE = ("services", "cli", "evaluation", "bench", "tests")
# Each layer of shared and the layers it may import (itself included).
SHARED_LAYERS: dict[str, frozenset[str]] = {
    "geometry": frozenset({"geometry"}),
    "imaging": frozenset({"imaging"}),
    "navigation": frozenset({"navigation", "geometry"}),
    "questions": frozenset({"questions", "geometry"}),
    "wire": frozenset({"wire", "geometry", "imaging", "questions", "navigation"}),
    "local": frozenset({"local", "wire", "geometry", "imaging", "questions", "navigation"}),
    "synthetic": frozenset({"synthetic", "geometry", "imaging", "questions", "navigation"}),
}
SERVICES = ("services.recon", "services.agent")
WORKER = "services.agent.sandbox.worker"
WORKER_MAY_IMPORT = ("services.agent.sandbox", "shared")
# Empty namespace packages the worker's own module path passes through (the jail mounts them).
WORKER_PATH_PACKAGES = frozenset({"services", "services.agent"})


def read_tree(root: Path) -> dict[str, str]:
    """{module name: source} of every .py file of the project's packages under `root`."""
    tree: dict[str, str] = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            relative = path.relative_to(root).with_suffix("")
            parts = relative.parts[:-1] if relative.name == "__init__" else relative.parts
            tree[".".join(parts)] = path.read_text()
    return tree


def import_graph(tree: Mapping[str, str]) -> dict[str, set[str]]:
    """{module: the project modules it imports}, from every import statement in its source."""
    return {module: _imports(module, source, tree) for module, source in tree.items()}


def _imports(module: str, source: str, tree: Mapping[str, str]) -> set[str]:
    is_package = _is_package(module, tree)
    found: set[str | None] = set()
    for name, level, names in _import_statements(source):
        if names is None:  # import a.b.c
            found.add(_known_prefix(name, tree))
            continue
        base = _absolute(module, is_package, name, level)
        for alias in names:
            submodule = f"{base}.{alias}"
            found.add(submodule if submodule in tree else _known_prefix(base, tree))
    found.discard(None)
    found.discard(module)
    return found


@functools.lru_cache(maxsize=4096)
def _import_statements(source: str) -> tuple[tuple[str, int, tuple[str, ...] | None], ...]:
    """(module, level, imported names or None for a plain `import`) of every import statement."""
    statements: list[tuple[str, int, tuple[str, ...] | None]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            statements += [(alias.name, 0, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            statements.append((node.module or "", node.level, tuple(alias.name for alias in node.names)))
    return tuple(statements)


def _is_package(module: str, tree: Mapping[str, str]) -> bool:
    """A package is a module with modules below it (its source is its `__init__.py`)."""
    return any(other.startswith(module + ".") for other in tree)


def _absolute(module: str, is_package: bool, name: str, level: int) -> str:
    """The absolute module a (possibly relative) `from` import names."""
    if level == 0:
        return name
    package = module.split(".") if is_package else module.split(".")[:-1]
    base = package[: len(package) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def _known_prefix(name: str, tree: Mapping[str, str]) -> str | None:
    """The longest prefix of a dotted name that is a project module (None: not ours)."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        candidate = ".".join(parts[:end])
        if candidate in tree:
            return candidate
    return None


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _shared_layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "shared" else None


def violations(tree: Mapping[str, str]) -> list[str]:
    """Every broken rule, one line each, sorted (an empty list: the layering holds)."""
    graph = import_graph(tree)
    found = _shared_violations(graph) + _service_violations(graph) + _worker_violations(graph)
    found += _cycle_violations(graph)
    return sorted(found)


def _shared_violations(graph: Mapping[str, set[str]]) -> list[str]:
    found = []
    for module, imported in graph.items():
        if not _within(module, "shared"):
            continue
        layer = _shared_layer(module)
        for target in sorted(imported):
            if any(_within(target, outside) for outside in SHARED_OUTSIDE):
                found.append(f"{module} imports {target}: shared imports nothing outside shared")
            elif layer in SHARED_LAYERS and _shared_layer(target) not in SHARED_LAYERS[layer] | {None}:
                found.append(
                    f"{module} imports {target}: shared.{layer} may import only "
                    + ", ".join(sorted(SHARED_LAYERS[layer]))
                )
    return found


def _service_violations(graph: Mapping[str, set[str]]) -> list[str]:
    found = []
    for service in SERVICES:
        others = [other for other in SERVICES if other != service]
        for module, imported in graph.items():
            if not _within(module, service):
                continue
            for target in sorted(imported):
                if any(_within(target, other) for other in others):
                    found.append(f"{module} imports {target}: recon and agent never import each other")
    return found


def _with_packages(module: str) -> Iterable[str]:
    """The module and its parent packages: importing it runs each of their `__init__` first."""
    parts = module.split(".")
    return (".".join(parts[:end]) for end in range(1, len(parts) + 1))


def _worker_violations(graph: Mapping[str, set[str]]) -> list[str]:
    """Each import by which the worker's closure would leave the sandbox and shared."""
    if WORKER not in graph:
        return [f"{WORKER} is missing"]

    def allowed(module: str) -> bool:
        return module in WORKER_PATH_PACKAGES or any(_within(module, ok) for ok in WORKER_MAY_IMPORT)

    found, seen, queue = [], set(), list(_with_packages(WORKER))
    while queue:
        module = queue.pop()
        if module in seen or module not in graph:
            continue
        seen.add(module)
        for target in sorted(graph[module]):
            for step in _with_packages(target):
                if allowed(step):
                    queue.append(step)
                elif step in graph:
                    found.append(
                        f"{module} imports {step}: the sandbox worker imports only "
                        "services.agent.sandbox and shared"
                    )
    return sorted(set(found))


def _cycle_violations(graph: Mapping[str, set[str]]) -> list[str]:
    found = []
    for service in SERVICES:
        inside = {m: {t for t in ts if _within(t, service)} for m, ts in graph.items() if _within(m, service)}
        for component in strongly_connected_components(inside):
            if len(component) > 1:
                found.append(f"import cycle in {service}: " + ", ".join(sorted(component)))
    return found


def strongly_connected_components(graph: Mapping[str, set[str]]) -> list[set[str]]:
    """Tarjan's algorithm, iterative (no recursion limit on long import chains)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components: list[set[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in graph:
                    continue
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                components.append(component)
    return components
