"""Static checks of a generated program before anything runs it.

The checker is the first of three walls (then the whitelisted builtins, then the process limits).
It rejects every construct that could reach interpreter internals: names and attributes starting
with `_`, frame / generator / code attributes, `str.format_map`, imports, classes, `global`,
`yield`, async, attribute writes. Messages are written for the code model, which reads them to
repair its program, so each says what is wrong, where, and what to do instead.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator

PROGRAM_NAME = "program"
# Helpers the rewriter calls (bound in the program's globals by builtins.program_globals).
FSTRING_FUNCTION_NAME = "__sandbox_fstring__"
PERCENT_FUNCTION_NAME = "__sandbox_percent__"
# Two-operand operators (operators.py): results pass the numpy dtype check.
RESULT_FUNCTION_NAME = "__sandbox_result__"
IN_PLACE_FUNCTION_NAME = "__sandbox_in_place__"
IN_PLACE_ITEM_FUNCTION_NAME = "__sandbox_in_place_item__"
SLICE_FUNCTION_NAME = "__sandbox_slice__"  # the builtin slice, which a program may shadow
# Every attribute a program reads goes through this (numpy_surface.attribute: the numpy allow-list).
ATTRIBUTE_FUNCTION_NAME = "__sandbox_attribute__"
MAX_PROGRAM_CHARS = 20_000
MAX_REPORTED_PROBLEMS = 5

# Modules whose import is a no-op: the sandbox already binds a restricted stand-in under this name.
ALLOWED_IMPORTS: dict[str, str] = {"numpy": "np", "math": "math"}
# `from math import atan2` becomes `atan2 = math.atan2` (the stand-in says if a name is missing).
FROM_IMPORT_MODULES: dict[str, str] = {"math": "math", "numpy": "np"}
UNUSED_NAME = "_"  # `for _ in range(n)`: the one name starting with '_' that is allowed

FORBIDDEN_NAMES = frozenset(
    {
        "exec", "eval", "open", "compile", "getattr", "setattr", "delattr", "globals",
        "locals", "vars", "input", "breakpoint", "help", "memoryview", "type", "object",
        "super", "classmethod", "staticmethod", "property", "exit", "quit", "importlib", "builtins",
        "reload", "id",
    }
)  # fmt: skip

# Attributes that reach files, raw memory, pickles, class hierarchies or modules.
FORBIDDEN_ATTRIBUTES = frozenset(
    {
        "format_map", "mro", "tofile", "dump", "dumps", "load", "loads", "save", "savez",
        "savez_compressed", "savetxt", "loadtxt", "genfromtxt", "fromfile", "frombuffer", "memmap",
        "ctypes", "ctypeslib", "lib", "base", "data", "os", "sys", "subprocess", "builtins", "modules",
        "import_module", "system", "popen", "testing", "f2py", "distutils", "setflags",
        # raw memory of numpy arrays: bytes, reinterpreting views, fields at offsets
        "tobytes", "tostring", "view", "getfield", "setfield", "itemset", "fromstring", "newbyteorder",
    }
)  # fmt: skip

# Frames (f_), generators (gi_), coroutines (cr_), async generators (ag_), code (co_), tracebacks (tb_)
# and the Python 2 function aliases lead from any generator expression to the interpreter's globals.
FORBIDDEN_ATTRIBUTE_PREFIXES = ("_", "gi_", "f_", "tb_", "co_", "cr_", "ag_", "func_", "im_")

_FORBIDDEN_NODES: dict[type, str] = {
    ast.ClassDef: "class definitions are not allowed; use functions, dicts and lists",
    ast.AsyncFunctionDef: "async functions are not allowed",
    ast.Await: "await is not allowed",
    ast.AsyncFor: "async for is not allowed",
    ast.AsyncWith: "async with is not allowed",
    ast.Global: "'global' is not allowed; pass values as arguments and return results",
    ast.Nonlocal: "'nonlocal' is not allowed; pass values as arguments and return results",
    ast.Yield: "'yield' is not allowed; build and return a list instead",
    ast.YieldFrom: "'yield from' is not allowed; build and return a list instead",
    ast.With: "'with' statements are not available in the sandbox",
}

_TOP_LEVEL_HINT = (
    "only function definitions and constant assignments may appear at the top level; "
    f"put the code inside def {PROGRAM_NAME}(input_scene)"
)


class ProgramRejected(ValueError):
    """The program may not run; the message is meant for the code model that wrote it."""


def validate_program(source: str, max_chars: int = MAX_PROGRAM_CHARS) -> ast.Module:
    """Parse and check `source`; return its syntax tree or raise ProgramRejected saying why."""
    if not isinstance(source, str) or not source.strip():
        raise ProgramRejected(f"the program is empty; define def {PROGRAM_NAME}(input_scene): ...")
    if len(source) > max_chars:
        raise ProgramRejected(f"the program is {len(source)} characters long; the limit is {max_chars}")
    if "\x00" in source:
        raise ProgramRejected("the program contains a NUL character")
    try:
        tree = ast.parse(source, filename="<program>", mode="exec")
    except SyntaxError as error:
        raise ProgramRejected(f"syntax error at line {error.lineno}: {error.msg}") from None
    except (RecursionError, MemoryError, SystemError):  # CPython 3.11 raises SystemError on deep nesting
        raise ProgramRejected("the program is nested too deeply to parse; simplify it") from None
    except ValueError as error:
        raise ProgramRejected(f"the program cannot be parsed: {error}") from None
    problems = list(dict.fromkeys(_top_level_problems(tree))) + _node_problems(tree)
    if problems:
        shown = problems[:MAX_REPORTED_PROBLEMS]
        more = len(problems) - len(shown)
        suffix = f" (and {more} more)" if more else ""
        raise ProgramRejected("; ".join(shown) + suffix)
    _check_compiles(source)
    return tree


def _check_compiles(source: str) -> None:
    """Errors only the compiler finds ('return' outside a function, too many nested blocks...)."""
    try:
        compile(source, "<program>", "exec", dont_inherit=True)
    except SyntaxError as error:
        raise ProgramRejected(f"syntax error at line {error.lineno}: {error.msg}") from None
    except (RecursionError, MemoryError):
        raise ProgramRejected("the program is nested too deeply to compile; simplify it") from None
    except ValueError as error:
        raise ProgramRejected(f"the program cannot be compiled: {error}") from None


def _at(node: ast.AST) -> str:
    return f"line {getattr(node, 'lineno', '?')}"


def _top_level_problems(tree: ast.Module) -> Iterator[str]:
    programs = [node for node in tree.body if isinstance(node, ast.FunctionDef) and node.name == PROGRAM_NAME]
    if not programs:
        yield f"the program must define a top-level function def {PROGRAM_NAME}(input_scene)"
    elif len(programs) > 1:
        lines = ", ".join(str(node.lineno) for node in programs)
        yield f"def {PROGRAM_NAME} is defined {len(programs)} times (lines {lines}); define it once"
    else:
        yield from _signature_problems(programs[0])
    for index, node in enumerate(tree.body):
        if isinstance(node, ast.FunctionDef | ast.Import | ast.ImportFrom):
            continue  # checked with every other node below
        if isinstance(node, ast.Assign | ast.AnnAssign) and _is_constant_assignment(node):
            continue
        if index == 0 and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            continue  # module docstring
        yield f"{_at(node)}: {_TOP_LEVEL_HINT}"


def _signature_problems(function: ast.FunctionDef) -> Iterator[str]:
    arguments = function.args
    positional = arguments.posonlyargs + arguments.args
    if len(positional) != 1 or arguments.vararg or arguments.kwarg or arguments.kwonlyargs:
        expected = f"def {PROGRAM_NAME}(input_scene)"
        yield f"{_at(function)}: {PROGRAM_NAME} must take exactly one argument: {expected}"


def _is_constant_assignment(node: ast.Assign | ast.AnnAssign) -> bool:
    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
    if node.value is None or not all(isinstance(target, ast.Name) for target in targets):
        return False
    allowed = (
        ast.Constant, ast.Tuple, ast.List, ast.Dict, ast.Set, ast.UnaryOp, ast.BinOp, ast.Name,
        ast.Attribute, ast.Load, ast.operator, ast.unaryop,
    )  # fmt: skip
    return all(isinstance(part, allowed) for part in ast.walk(node.value))


def _node_problems(tree: ast.Module) -> list[str]:
    """Every forbidden construct, in source order, each reported once."""
    format_calls = {
        id(node.func)
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "format"
    }
    found: dict[str, tuple[int, int]] = {}
    for node in ast.walk(tree):  # iterative: deep programs cannot overflow the checker's stack
        problem = _node_problem(node, format_calls)
        if problem:
            found.setdefault(
                f"{_at(node)}: {problem}", (getattr(node, "lineno", 0), getattr(node, "col_offset", 0))
            )
    return sorted(found, key=found.__getitem__)


def _node_problem(node: ast.AST, format_calls: set[int]) -> str | None:
    for node_type, message in _FORBIDDEN_NODES.items():
        if isinstance(node, node_type):
            return message
    if isinstance(node, ast.Import | ast.ImportFrom):
        return _import_problem(node)
    if isinstance(node, ast.Name):
        return _name_problem(node.id)
    if isinstance(node, ast.arg):
        return _name_problem(node.arg)
    if isinstance(node, ast.FunctionDef | ast.Lambda):
        if isinstance(node, ast.FunctionDef) and node.decorator_list:
            return "decorators are not allowed"
        return _name_problem(node.name) if isinstance(node, ast.FunctionDef) else None
    if isinstance(node, ast.Attribute):
        return _attribute_problem(node, format_calls)
    if isinstance(node, ast.keyword) and node.arg is not None:
        return _name_problem(node.arg)
    if isinstance(node, ast.alias):
        return None  # reported with its import
    if isinstance(node, ast.ExceptHandler) and node.name:
        return _name_problem(node.name)
    if isinstance(node, ast.MatchAs | ast.MatchStar) and node.name:
        return _name_problem(node.name)
    if isinstance(node, ast.MatchMapping) and node.rest:
        return _name_problem(node.rest)
    if isinstance(node, ast.MatchClass):
        return "class patterns in match statements are not allowed"
    return None


def _import_problem(node: ast.Import | ast.ImportFrom) -> str | None:
    if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module in FROM_IMPORT_MODULES:
        for alias in node.names:
            if alias.name == "*":
                return f"'from {node.module} import *' is not allowed; import the names you use"
            problem = _name_problem(alias.name) or _name_problem(alias.asname or alias.name)
            if problem:
                return problem
        return None  # rewritten to assignments from the sandbox's stand-in
    if isinstance(node, ast.Import) and all(
        alias.name in ALLOWED_IMPORTS and alias.asname in (None, ALLOWED_IMPORTS[alias.name])
        for alias in node.names
    ):
        return None  # `import numpy as np` / `import math`: the names are already bound
    return (
        "imports are not allowed; np (a restricted numpy), math and pySpatial are already "
        "available: remove the import"
    )


def _name_problem(name: str) -> str | None:
    if name == UNUSED_NAME:
        return None
    if name.startswith("_"):
        return f"the name '{name}' is not allowed: names may not start with '_'"
    if name in FORBIDDEN_NAMES:
        return f"'{name}' is not available in the sandbox (choose another name if it is your variable)"
    return None


def _attribute_problem(node: ast.Attribute, format_calls: set[int]) -> str | None:
    attribute = node.attr
    if attribute.startswith(FORBIDDEN_ATTRIBUTE_PREFIXES):
        return f"the attribute '.{attribute}' is not allowed"
    if attribute in FORBIDDEN_ATTRIBUTES:
        return f"the attribute '.{attribute}' is not available in the sandbox"
    if attribute == "format" and id(node) not in format_calls:
        return "'.format' may only be called directly, as in '{:.2f}'.format(x)"
    if not isinstance(node.ctx, ast.Load):
        return f"assigning or deleting attributes ('.{attribute}') is not allowed; use a dict or a variable"
    return None


class _ExecutionRewriter(ast.NodeTransformer):
    """Drop the allowed no-op imports, turn `from math import x` into `x = math.x`, route
    `x.format(...)`, f-string fields and `a % b` through the sandbox's formatters (which refuse
    attribute lookups in fields and hide heap addresses), every attribute read through the
    sandbox's attribute check (numpy's allow-list), and every two-operand operator and augmented
    assignment through the numpy dtype check of its result (operators.py)."""

    def __init__(self, format_function_name: str) -> None:
        self.format_function_name = format_function_name

    def visit_Import(self, node: ast.Import) -> ast.AST:
        return ast.copy_location(ast.Pass(), node)  # validated: only allowed modules get here

    def visit_ImportFrom(self, node: ast.ImportFrom) -> ast.AST:
        module = FROM_IMPORT_MODULES[node.module or ""]  # validated: only these modules get here
        assignments = [
            ast.Assign(
                targets=[ast.Name(id=alias.asname or alias.name, ctx=ast.Store())],
                value=ast.Attribute(
                    value=ast.Name(id=module, ctx=ast.Load()), attr=alias.name, ctx=ast.Load()
                ),
            )
            for alias in node.names
        ]
        return [ast.copy_location(assignment, node) for assignment in assignments]

    def visit_Attribute(self, node: ast.Attribute) -> ast.AST:
        self.generic_visit(node)
        if node.attr == "format" or not isinstance(node.ctx, ast.Load):
            return node  # `.format` calls are rewritten by visit_Call; writes were rejected
        call = ast.Call(
            func=ast.Name(id=ATTRIBUTE_FUNCTION_NAME, ctx=ast.Load()),
            args=[node.value, ast.Constant(value=node.attr)],
            keywords=[],
        )
        return ast.copy_location(call, node)

    def visit_FormattedValue(self, node: ast.FormattedValue) -> ast.AST:
        self.generic_visit(node)
        spec = node.format_spec if node.format_spec is not None else ast.Constant(value="")
        call = ast.Call(
            func=ast.Name(id=FSTRING_FUNCTION_NAME, ctx=ast.Load()),
            args=[node.value, ast.Constant(value=node.conversion), spec],
            keywords=[],
        )
        return ast.copy_location(ast.FormattedValue(value=call, conversion=-1, format_spec=None), node)

    def visit_AugAssign(self, node: ast.AugAssign) -> ast.AST:
        """`x op= v` -> `x = in_place(x, v, 'op=')`; `c[k] op= v` -> `in_place_item(c, k, v, 'op=')`."""
        self.generic_visit(node)
        symbol = ast.Constant(value=_OPERATOR_SYMBOLS[type(node.op)] + "=")
        target = node.target
        if isinstance(target, ast.Name):
            current = ast.Name(id=target.id, ctx=ast.Load())
            call = _call(IN_PLACE_FUNCTION_NAME, current, node.value, symbol)
            return ast.copy_location(ast.Assign(targets=[target], value=call), node)
        if isinstance(target, ast.Subscript):
            key = _slices_as_calls(target.slice)
            call = _call(IN_PLACE_ITEM_FUNCTION_NAME, target.value, key, node.value, symbol)
            return ast.copy_location(ast.Expr(value=call), node)
        return node  # attribute targets were rejected by the checker

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.op, ast.Mod):
            return ast.copy_location(_call(PERCENT_FUNCTION_NAME, node.left, node.right), node)
        symbol = ast.Constant(value=_OPERATOR_SYMBOLS[type(node.op)])
        return ast.copy_location(_call(RESULT_FUNCTION_NAME, node, symbol), node)

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.func, ast.Attribute) and node.func.attr == "format":
            target = ast.Name(id=self.format_function_name, ctx=ast.Load())
            return ast.copy_location(
                ast.Call(func=target, args=[node.func.value, *node.args], keywords=node.keywords), node
            )
        return node


_OPERATOR_SYMBOLS: dict[type, str] = {
    ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.MatMult: "@", ast.Div: "/", ast.FloorDiv: "//",
    ast.Mod: "%", ast.Pow: "**", ast.LShift: "<<", ast.RShift: ">>", ast.BitOr: "|", ast.BitXor: "^",
    ast.BitAnd: "&",
}  # fmt: skip


def _call(function_name: str, *arguments: ast.expr) -> ast.Call:
    return ast.Call(func=ast.Name(id=function_name, ctx=ast.Load()), args=list(arguments), keywords=[])


def _slices_as_calls(key: ast.expr) -> ast.expr:
    """A subscript's key as a value: `1:3` becomes `slice(1, 3, None)` (also inside a tuple)."""
    if isinstance(key, ast.Slice):
        bounds = [
            part if part is not None else ast.Constant(value=None)
            for part in (key.lower, key.upper, key.step)
        ]
        return _call(SLICE_FUNCTION_NAME, *bounds)
    if isinstance(key, ast.Tuple):
        return ast.Tuple(elts=[_slices_as_calls(element) for element in key.elts], ctx=ast.Load())
    return key


def prepare_for_execution(tree: ast.Module, format_function_name: str) -> ast.Module:
    """The validated tree as it is executed (the input tree is modified)."""
    rewritten = _ExecutionRewriter(format_function_name).visit(tree)
    return ast.fix_missing_locations(rewritten)
