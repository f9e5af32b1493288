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

from services.agent.sandbox import numpy_surface, operators
from services.agent.sandbox.text import hide_addresses
from services.agent.sandbox.validation import (
    ATTRIBUTE_FUNCTION_NAME,
    FSTRING_FUNCTION_NAME,
    IN_PLACE_FUNCTION_NAME,
    IN_PLACE_ITEM_FUNCTION_NAME,
    PERCENT_FUNCTION_NAME,
    RESULT_FUNCTION_NAME,
    SLICE_FUNCTION_NAME,
)

__all__ = [
    "FORMAT_FUNCTION_NAME",
    "FSTRING_FUNCTION_NAME",
    "PERCENT_FUNCTION_NAME",
    "hide_addresses",
    "program_globals",
]

MAX_RANGE_ITEMS = 10_000_000
# Injected by the rewriter (validation.prepare_for_execution); programs cannot spell these names.
FORMAT_FUNCTION_NAME = "__sandbox_format__"  # x.format(...)

_SAFE_FUNCTIONS: tuple[Callable[..., Any] | type, ...] = (
    abs, all, any, bin, bool, callable, chr, dict, divmod, enumerate, filter, float, frozenset, hex,
    int, isinstance, iter, len, list, map, max, min, next, oct, ord, pow, reversed, round, set, slice,
    sorted, sum, tuple, zip,
)  # fmt: skip

_SAFE_EXCEPTIONS: tuple[type[BaseException], ...] = (
    ArithmeticError, AssertionError, AttributeError, Exception, IndexError, KeyError, LookupError,
    NameError, NotImplementedError, OverflowError, RuntimeError, StopIteration, TypeError, ValueError,
    ZeroDivisionError,
)  # fmt: skip

# Plain values and scalar types (scalar constructors take a number, not a buffer). The functions,
# with the arguments each accepts, are numpy_surface.FUNCTIONS and LINALG_FUNCTIONS.
NUMPY_VALUES = ("e", "float32", "float64", "inf", "int32", "int64", "nan", "newaxis", "pi", "uint8")
# Builtins that compute a new value from two operands, as the operators do (`sum([a, [10**30]])`
# adds a list to an array in C, where the rewriter cannot see it): their results are checked.
_ARITHMETIC_BUILTINS = ("divmod", "pow", "sum")


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


class _TypeStandInMeta(type):
    """Metaclass of stand-ins for real types: isinstance works, everything else is chosen."""

    def __instancecheck__(cls, value: object) -> bool:
        return isinstance(value, cls._sandbox_real)

    def __subclasscheck__(cls, subclass: type) -> bool:
        return issubclass(subclass, cls._sandbox_real)

    def __call__(cls, *arguments: Any, **keywords: Any) -> Any:
        return cls._sandbox_call(*arguments, **keywords)

    def __getattr__(cls, name: str) -> Any:
        if name.startswith("_") or name not in cls._sandbox_members:
            raise AttributeError(f"{cls._sandbox_label}.{name} is not available in the sandbox")
        return getattr(cls._sandbox_real, name)

    def __repr__(cls) -> str:
        return f"<class '{cls._sandbox_label}'>"


def type_stand_in(real: type, label: str, call: Callable[..., Any], members: tuple[str, ...] = ()) -> type:
    """A name that passes `isinstance(x, stand_in)` like `real`, calls `call`, and offers `members`."""
    namespace = {
        "_sandbox_real": real,
        "_sandbox_label": label,
        "_sandbox_call": staticmethod(call),
        "_sandbox_members": frozenset(members),
        "__slots__": (),
    }
    return _TypeStandInMeta(label.rsplit(".", 1)[-1], (), namespace)


def _refuse_ndarray_constructor(*arguments: Any, **keywords: Any) -> Any:
    raise TypeError("np.ndarray(...) is not available in the sandbox; use np.array, np.zeros or np.ones")


def _numpy_functions(prefix: str, module: Any, table: dict[str, numpy_surface.Signature]) -> dict[str, Any]:
    return {
        name: numpy_surface.CheckedCallable(f"{prefix}.{name}", getattr(module, name), accepted)
        for name, accepted in table.items()
    }


def restricted_numpy() -> ReadOnlyNamespace:
    linalg_members = _numpy_functions("np.linalg", numpy.linalg, numpy_surface.LINALG_FUNCTIONS)
    linalg_members["LinAlgError"] = numpy.linalg.LinAlgError  # an exception class programs catch
    members = _numpy_functions("np", numpy, numpy_surface.FUNCTIONS)
    members.update({name: getattr(numpy, name) for name in NUMPY_VALUES})
    members["ndarray"] = type_stand_in(numpy.ndarray, "np.ndarray", _refuse_ndarray_constructor)
    members["linalg"] = ReadOnlyNamespace("np.linalg", linalg_members)
    return ReadOnlyNamespace("np", members)


def restricted_math() -> ReadOnlyNamespace:
    # math is pure C arithmetic; only its public functions and constants are copied. math.prod
    # multiplies whatever it is given (an array by a list, too), so every result is checked.
    members = {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
    return ReadOnlyNamespace(
        "math",
        {
            name: numpy_surface.checked_results(f"math.{name}", value) if callable(value) else value
            for name, value in members.items()
        },
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
        capture.write(sep.join(safe_str(value) for value in values) + end)
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


def safe_str(value: object = "", *arguments: Any) -> str:
    if isinstance(value, str) and not arguments:
        return value
    return hide_addresses(str(value, *arguments))


def safe_repr(value: object) -> str:
    return hide_addresses(repr(value))


def safe_ascii(value: object) -> str:
    return hide_addresses(ascii(value))


def safe_format_value(value: object, spec: str = "") -> str:
    return hide_addresses(format(value, spec))


_CONVERSIONS: dict[int, Callable[[object], str]] = {ord("s"): str, ord("r"): repr, ord("a"): ascii}


def fstring_value(value: object, conversion: int, spec: str) -> str:
    """One `{value!conversion:spec}` of an f-string (rewritten by the validator's rewriter)."""
    if conversion in _CONVERSIONS:
        value = _CONVERSIONS[conversion](value)
    return hide_addresses(format(value, spec))


def safe_hasattr(value: object, name: str) -> bool:
    """hasattr for public attributes; names starting with '_' always answer False."""
    if not isinstance(name, str):
        raise TypeError("hasattr(): attribute name must be a string")
    if name.startswith(("_", "gi_", "f_", "tb_", "co_", "cr_", "ag_")):
        return False
    return numpy_surface.has_attribute(value, name)


# The program's `str`: isinstance(x, str) and str.join / str.lower ... work; str(x) hides addresses.
_STR_METHODS = tuple(name for name in dir(str) if not name.startswith("_") and name != "format_map")
SAFE_STR = type_stand_in(str, "str", safe_str, _STR_METHODS)


def safe_format(template: object, *args: object, **kwargs: object) -> str:
    """Stands in for every `x.format(...)` call of a program (see validation.prepare_for_execution)."""
    if template in (str, SAFE_STR) and args:  # str.format(template, ...)
        template, args = args[0], args[1:]
    if not isinstance(template, str):
        raise TypeError(f"'{type(template).__name__}' object has no format method")
    return hide_addresses(_FieldCheckingFormatter().vformat(template, args, kwargs))


def safe_builtins(capture: OutputCapture) -> dict[str, Any]:
    names: dict[str, Any] = {item.__name__: item for item in _SAFE_FUNCTIONS + _SAFE_EXCEPTIONS}
    names["range"] = bounded_range
    names["print"] = make_print(capture)
    names["str"] = SAFE_STR
    names["repr"] = safe_repr
    names["ascii"] = safe_ascii
    names["format"] = safe_format_value
    names["hasattr"] = safe_hasattr
    for name in _ARITHMETIC_BUILTINS:
        names[name] = numpy_surface.checked_results(f"{name}()", names[name])
    names["True"], names["False"], names["None"] = True, False, None
    return names


def program_globals(capture: OutputCapture, extra: dict[str, Any]) -> dict[str, Any]:
    """The global namespace a program runs in; `extra` adds the pySpatial API."""
    numpy_stand_in = restricted_numpy()
    names: dict[str, Any] = {
        "__builtins__": safe_builtins(capture),
        "__name__": "program",
        FORMAT_FUNCTION_NAME: safe_format,
        FSTRING_FUNCTION_NAME: fstring_value,
        PERCENT_FUNCTION_NAME: operators.percent,
        RESULT_FUNCTION_NAME: operators.result,
        IN_PLACE_FUNCTION_NAME: operators.in_place,
        IN_PLACE_ITEM_FUNCTION_NAME: operators.in_place_item,
        SLICE_FUNCTION_NAME: slice,
        ATTRIBUTE_FUNCTION_NAME: numpy_surface.attribute,
        "np": numpy_stand_in,
        "numpy": numpy_stand_in,
        "math": restricted_math(),
    }
    names.update(extra)
    return names
