"""What a program can name: a whitelist of builtins, a captured `print`, a restricted numpy.

Nothing here can open files, import modules or reach interpreter internals. Real numpy functions
are handed out one by one (their dunder attributes are unreachable: the validator rejects every
name and attribute starting with `_`), never the numpy module itself.
"""

from __future__ import annotations

import math
import string
from collections.abc import Callable
from typing import Any

import numpy

MAX_RANGE_ITEMS = 10_000_000
FORMAT_FUNCTION_NAME = "__sandbox_format__"  # injected by the rewriter; programs cannot spell it

_SAFE_FUNCTIONS: tuple[Callable[..., Any] | type, ...] = (
    abs, all, any, bool, chr, dict, divmod, enumerate, filter, float, frozenset, int, isinstance, iter,
    len, list, map, max, min, next, ord, pow, repr, reversed, round, set, slice, sorted, str, sum,
    tuple, zip,
)  # fmt: skip

_SAFE_EXCEPTIONS: tuple[type[BaseException], ...] = (
    ArithmeticError, AssertionError, Exception, IndexError, KeyError, LookupError, OverflowError,
    RuntimeError, StopIteration, TypeError, ValueError, ZeroDivisionError,
)  # fmt: skip

NUMPY_NAMES = (
    "abs", "allclose", "arange", "arccos", "arcsin", "arctan", "arctan2", "argmax", "argmin",
    "argsort", "array", "array_equal", "asarray", "ceil", "clip", "column_stack", "concatenate",
    "cos", "cross", "cumsum", "deg2rad", "degrees", "diag", "dot", "e", "exp", "eye", "float32",
    "float64", "floor", "hstack", "inf", "int32", "int64", "isclose", "isfinite", "isnan", "linspace",
    "log", "matmul", "max", "maximum", "mean", "median", "min", "minimum", "nan", "ndarray", "newaxis",
    "ones", "outer", "pi", "rad2deg", "radians", "round", "sign", "sin", "sort", "sqrt", "square",
    "stack", "std", "sum", "tan", "trace", "transpose", "uint8", "vstack", "where", "zeros",
    "zeros_like", "ones_like",
)  # fmt: skip
NUMPY_LINALG_NAMES = ("det", "inv", "norm", "pinv", "solve", "svd")


class ReadOnlyNamespace:
    """A module stand-in exposing a fixed set of members; anything else is a clear AttributeError."""

    __slots__ = ("_label", "_members")

    def __init__(self, label: str, members: dict[str, Any]) -> None:
        object.__setattr__(self, "_label", label)
        object.__setattr__(self, "_members", dict(members))

    def __getattr__(self, name: str) -> Any:
        members = object.__getattribute__(self, "_members")
        if name in members:
            return members[name]
        label = object.__getattribute__(self, "_label")
        raise AttributeError(f"{label}.{name} is not available in the sandbox")

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("sandbox modules are read-only")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("sandbox modules are read-only")

    def __repr__(self) -> str:
        return f"<sandbox module {object.__getattribute__(self, '_label')}>"


def restricted_numpy() -> ReadOnlyNamespace:
    linalg = ReadOnlyNamespace(
        "np.linalg", {name: getattr(numpy.linalg, name) for name in NUMPY_LINALG_NAMES}
    )
    members = {name: getattr(numpy, name) for name in NUMPY_NAMES}
    members["linalg"] = linalg
    return ReadOnlyNamespace("np", members)


def restricted_math() -> ReadOnlyNamespace:
    # math is pure C arithmetic; only its public functions and constants are copied.
    return ReadOnlyNamespace(
        "math", {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
    )


class OutputCapture:
    """Collects printed text up to `max_chars`; notes (and keeps no more) when a program prints more."""

    def __init__(self, max_chars: int) -> None:
        self.max_chars = max_chars
        self.parts: list[str] = []
        self.size = 0
        self.overflowed = False

    def write(self, text: str) -> None:
        room = self.max_chars - self.size
        if len(text) > room:
            self.overflowed = True
            text = text[: max(room, 0)]
        self.parts.append(text)
        self.size += len(text)

    def text(self) -> str:
        return "".join(self.parts)


class OutputLimitExceeded(Exception):
    """Raised inside the program when it prints more than the sandbox keeps."""


def make_print(capture: OutputCapture) -> Callable[..., None]:
    def print(
        *values: object,
        sep: str | None = " ",
        end: str | None = "\n",
        file: object = None,
        flush: bool = False,
    ) -> None:
        if file is not None:
            raise TypeError("print(file=...) is not available in the sandbox")
        sep = " " if sep is None else str(sep)
        end = "\n" if end is None else str(end)
        capture.write(sep.join(str(value) for value in values) + end)
        if capture.overflowed:
            raise OutputLimitExceeded(f"the program printed more than {capture.max_chars} characters")

    return print


def bounded_range(*arguments: int) -> range:
    """`range`, refusing sizes that could only be a time or memory bomb."""
    span = range(*arguments)
    try:
        size = len(span)
    except OverflowError:
        size = MAX_RANGE_ITEMS + 1
    if size > MAX_RANGE_ITEMS:
        raise ValueError(f"range of more than {MAX_RANGE_ITEMS} items is not allowed in the sandbox")
    return span


class _FieldCheckingFormatter(string.Formatter):
    """str.format that only substitutes arguments: '{0.attr}' and '{0[key]}' would reach internals."""

    def get_field(self, field_name: str, args: Any, kwargs: Any) -> Any:
        if "." in field_name or "[" in field_name:
            raise ValueError(
                f"format field '{{{field_name}}}' is not allowed: fields may only name an argument"
            )
        return super().get_field(field_name, args, kwargs)


def safe_format(template: object, *args: object, **kwargs: object) -> str:
    """Stands in for every `x.format(...)` call of a program (see validation.prepare_for_execution)."""
    if template is str and args:  # str.format(template, ...)
        template, args = args[0], args[1:]
    if not isinstance(template, str):
        raise TypeError(f"'{type(template).__name__}' object has no format method")
    return _FieldCheckingFormatter().vformat(template, args, kwargs)


def safe_builtins(capture: OutputCapture) -> dict[str, Any]:
    names: dict[str, Any] = {item.__name__: item for item in _SAFE_FUNCTIONS + _SAFE_EXCEPTIONS}
    names["range"] = bounded_range
    names["print"] = make_print(capture)
    names["True"], names["False"], names["None"] = True, False, None
    return names


def program_globals(capture: OutputCapture, extra: dict[str, Any]) -> dict[str, Any]:
    """The global namespace a program runs in; `extra` adds the pySpatial API."""
    numpy_stand_in = restricted_numpy()
    names: dict[str, Any] = {
        "__builtins__": safe_builtins(capture),
        "__name__": "program",
        FORMAT_FUNCTION_NAME: safe_format,
        "np": numpy_stand_in,
        "numpy": numpy_stand_in,
        "math": restricted_math(),
    }
    names.update(extra)
    return names
