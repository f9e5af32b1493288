"""The numpy surface a program may touch, as allow-lists decided in one place.

Three lists, each checked where every use passes through:
- attributes: every `x.name` a program reads is routed here by the validator's rewriter
  (validation.ATTRIBUTE_FUNCTION_NAME), so for any numpy array, numpy scalar, dtype or numpy type the
  program holds, wherever it came from (the restricted `np`, an API tool, a scalar method, an
  operator), only the names below exist: read-only and arithmetic members, no method that changes
  a buffer in place or frees one (`resize`, `put`, `fill`, `sort`...), none that exposes raw memory
  (`view`, `data`, `base`, `ctypes`, `tobytes`, `strides`...). Checking the name at the one place
  every access passes through also covers the numpy scalars, which, unlike arrays, cannot be
  replaced by a restricted subclass.
- arguments: every numpy callable a program gets (the `np` functions, array and scalar methods)
  takes only the arguments its `Signature` names: how many by position and which by keyword. So
  `out=`, `where=` (which returns an output buffer numpy never wrote: uninitialised heap memory),
  `signature=`, `casting=`, `order=`, `subok=`, `initial=` and `like=` exist nowhere unless listed,
  and a positional `out` (`np.abs(x, o)`, `a.take(i, 0, o)`) is one positional too many.
- dtypes: only bool, signed and unsigned integers, floats and complex (`NUMERIC_DTYPE_KINDS`). A
  `dtype` argument, by position or keyword, is refused before the call; every result (of the
  callables, of the operators the rewriter routes here, of the arithmetic builtins) is checked
  after it. So no object array (a list holding a Python int beyond 64 bits, a string or a tool
  object), no string (`U`, `S`, StringDType `T`), raw (`V`), structured or datetime array reaches
  a program.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy

from services.agent.sandbox.text import hide_addresses

NUMERIC_DTYPE_KINDS = "biufc"  # bool, signed, unsigned, float, complex: everything else is refused
NUMERIC_DTYPES_HINT = "np.float64, np.float32, np.int64, np.int32, np.uint8, float, int or bool"


class Signature(NamedTuple):
    """The arguments a numpy callable accepts in the sandbox."""

    positional: tuple[str, ...]  # names of the parameters that may be passed by position, in order
    keywords: frozenset[str]  # parameters that may be passed by name
    most_positional: int  # len(positional), or no bound (`a.reshape(2, 3)`, `a.item(0, 1)`)
    dtype_position: int  # where a positional dtype sits, -1 for none


def signature(positional: str = "", keywords: str = "", variadic: bool = False) -> Signature:
    names = tuple(positional.split())
    dtype_position = names.index("dtype") if "dtype" in names else -1
    return Signature(
        names, frozenset(keywords.split()), sys.maxsize if variadic else len(names), dtype_position
    )


_REDUCTION = signature("axis dtype", "axis dtype keepdims")  # sum, mean, prod
_EXTREMUM = signature("axis", "axis keepdims")  # min, max, argmin, argmax, any, all
_NO_ARGUMENTS = signature()
# Array and numpy scalar methods, by name (numpy 2's own parameter names).
METHODS: dict[str, Signature] = {
    "reshape": signature(variadic=True),
    "transpose": signature(variadic=True),
    "item": signature(variadic=True),
    "copy": _NO_ARGUMENTS,
    "flatten": _NO_ARGUMENTS,
    "ravel": _NO_ARGUMENTS,
    "nonzero": _NO_ARGUMENTS,
    "conj": _NO_ARGUMENTS,
    "conjugate": _NO_ARGUMENTS,
    "tolist": _NO_ARGUMENTS,
    "astype": signature("dtype", "dtype"),
    "squeeze": signature("axis", "axis"),
    "swapaxes": signature("axis1 axis2"),
    "diagonal": signature("offset axis1 axis2", "offset axis1 axis2"),
    "trace": signature("offset axis1 axis2", "offset axis1 axis2"),
    "repeat": signature("repeats axis", "repeats axis"),
    "take": signature("indices axis", "indices axis"),
    "sum": _REDUCTION,
    "mean": _REDUCTION,
    "prod": _REDUCTION,
    "std": signature("axis dtype", "axis dtype ddof keepdims"),
    "var": signature("axis dtype", "axis dtype ddof keepdims"),
    "cumsum": signature("axis dtype", "axis dtype"),
    "cumprod": signature("axis dtype", "axis dtype"),
    "min": _EXTREMUM,
    "max": _EXTREMUM,
    "argmin": _EXTREMUM,
    "argmax": _EXTREMUM,
    "any": _EXTREMUM,
    "all": _EXTREMUM,
    "argsort": signature("axis kind", "axis kind stable"),
    "clip": signature("min max", "min max"),
    "round": signature("decimals", "decimals"),
    "dot": signature("other"),
}
ARRAY_ATTRIBUTES = frozenset(
    {"shape", "dtype", "ndim", "size", "itemsize", "T", "real", "imag"}  # read-only facts
    | METHODS.keys()
)
DTYPE_ATTRIBUTES = frozenset({"name", "kind", "itemsize", "char"})

_UNARY_UFUNCS = (
    "abs", "arccos", "arcsin", "arctan", "ceil", "cos", "deg2rad", "degrees", "exp", "floor", "isfinite",
    "isnan", "log", "rad2deg", "radians", "sign", "sin", "sqrt", "square", "tan",
)  # fmt: skip
_BINARY_UFUNCS = ("arctan2", "matmul", "maximum", "minimum")
_AXIS_REDUCTION = signature("a axis dtype", "axis dtype keepdims")
_AXIS_EXTREMUM = signature("a axis", "axis keepdims")
_TOLERANCE = signature("a b rtol atol equal_nan", "rtol atol equal_nan")
_SORT = signature("a axis kind", "axis kind stable")
# The `np` functions: each builds new arrays from values (never from buffers, strides or offsets).
# Ufuncs take their operands only: no out / where / dtype / signature / casting / order / subok.
FUNCTIONS: dict[str, Signature] = {
    **{name: signature("x") for name in _UNARY_UFUNCS},
    **{name: signature("x1 x2") for name in _BINARY_UFUNCS},
    "all": _AXIS_EXTREMUM,
    "any": _AXIS_EXTREMUM,
    "max": _AXIS_EXTREMUM,
    "min": _AXIS_EXTREMUM,
    "argmax": _AXIS_EXTREMUM,
    "argmin": _AXIS_EXTREMUM,
    "median": _AXIS_EXTREMUM,
    "sum": _AXIS_REDUCTION,
    "mean": _AXIS_REDUCTION,
    "std": signature("a axis dtype", "axis dtype ddof keepdims"),
    "cumsum": signature("a axis dtype", "axis dtype"),
    "allclose": _TOLERANCE,
    "isclose": _TOLERANCE,
    "array_equal": signature("a1 a2 equal_nan", "equal_nan"),
    "sort": _SORT,
    "argsort": _SORT,
    "unique": signature(
        "ar return_index return_inverse return_counts axis", "return_index return_inverse return_counts axis"
    ),
    "array": signature("object dtype", "dtype copy ndmin"),
    "asarray": signature("a dtype", "dtype"),
    "arange": signature("start stop step", "stop step dtype"),
    "linspace": signature("start stop num endpoint retstep dtype axis", "num endpoint retstep dtype axis"),
    "zeros": signature("shape dtype", "dtype"),
    "ones": signature("shape dtype", "dtype"),
    "zeros_like": signature("a dtype", "dtype"),
    "ones_like": signature("a dtype", "dtype"),
    "eye": signature("N M k dtype", "M k dtype"),
    "diag": signature("v k", "k"),
    "clip": signature("a a_min a_max", "a_min a_max min max"),
    "round": signature("a decimals", "decimals"),
    "where": signature("condition x y"),
    "transpose": signature("a axes", "axes"),
    "trace": signature("a offset axis1 axis2", "offset axis1 axis2"),
    "cross": signature("a b", "axisa axisb axisc axis"),
    "dot": signature("a b"),
    "outer": signature("a b"),
    "concatenate": signature("arrays axis", "axis"),
    "stack": signature("arrays axis", "axis"),
    "hstack": signature("tup"),
    "vstack": signature("tup"),
    "column_stack": signature("tup"),
}
LINALG_FUNCTIONS: dict[str, Signature] = {
    "det": signature("a"),
    "inv": signature("a"),
    "solve": signature("a b"),
    "norm": signature("x ord axis keepdims", "ord axis keepdims"),
    "pinv": signature("a rcond hermitian", "rcond hermitian rtol"),
    "svd": signature("a full_matrices compute_uv hermitian", "full_matrices compute_uv hermitian"),
}


def _numeric_dtype(dtype: Any, label: str) -> numpy.dtype:
    """`dtype` as a numpy dtype if it is a numeric one; TypeError naming what is allowed if not."""
    try:
        resolved = numpy.dtype(dtype)
    except (TypeError, ValueError, RuntimeError):  # RuntimeError: numpy's parser of '(2,)f8' compiles
        shown = hide_addresses(repr(dtype))[:80]  # a function's repr names its heap address
        raise TypeError(f"{shown} is not a numpy dtype; use {NUMERIC_DTYPES_HINT}") from None
    if resolved.kind in NUMERIC_DTYPE_KINDS:
        return resolved
    if label.endswith(".astype"):
        raise TypeError(
            f"astype({resolved}) is not available in the sandbox: arrays convert only to numeric "
            f"dtypes ({NUMERIC_DTYPES_HINT})"
        )
    raise TypeError(
        f"numpy arrays of dtype {resolved} are not available in the sandbox; only numbers are "
        f"({NUMERIC_DTYPES_HINT})"
    )


def check_arguments(label: str, accepted: Signature, arguments: tuple, keywords: dict[str, Any]) -> None:
    """TypeError unless `arguments` and `keywords` fit `accepted`; numeric dtypes only."""
    if len(arguments) > accepted.most_positional:
        names = ", ".join(accepted.positional) or "no argument"
        raise TypeError(
            f"{label}() takes {names} by position in the sandbox; {len(arguments)} positional "
            "arguments were given"
        )
    for name in keywords:
        if name not in accepted.keywords:
            offer = f"only {', '.join(sorted(accepted.keywords))}" if accepted.keywords else "none"
            raise TypeError(
                f"{label}({name}=...) is not available in the sandbox; keyword arguments {label} "
                f"accepts: {offer}"
            )
    if keywords.get("dtype") is not None:
        _numeric_dtype(keywords["dtype"], label)
    position = accepted.dtype_position
    if 0 <= position < len(arguments) and arguments[position] is not None:
        _numeric_dtype(arguments[position], label)


_NUMPY_VALUES = (numpy.ndarray, numpy.generic)  # a tuple: isinstance on a `|` union is slower


def _forbidden_dtype(value: Any) -> numpy.dtype | None:
    if isinstance(value, _NUMPY_VALUES) and value.dtype.kind not in NUMERIC_DTYPE_KINDS:
        return value.dtype
    if isinstance(value, tuple):  # np.unique(..., return_counts=True), np.linalg.svd, divmod
        for item in value:
            found = _forbidden_dtype(item)
            if found is not None:
                return found
    return None


def checked_result(label: str, value: Any) -> Any:
    """`value`, unless it is (or a tuple holding) a numpy array or scalar of a refused dtype."""
    refused = _forbidden_dtype(value)
    if refused is not None:
        raise TypeError(
            f"{label} would make a numpy array of dtype {refused}; only numbers (bool, int, float, "
            "complex) are available in the sandbox"
        )
    return value


class CheckedCallable:
    """A numpy callable taking only the arguments `accepted` names, refusing non-numeric dtypes in
    and out. It offers no attribute (so no ufunc `.reduce`, `.accumulate`, `.outer`, `.at` or
    `.reduceat`, which take `out=` and `where=` of their own) and no way back to the real callable."""

    __slots__ = ("_accepted", "_function", "_label")

    def __init__(self, label: str, function: Callable[..., Any], accepted: Signature) -> None:
        self._label, self._function, self._accepted = label, function, accepted

    def __call__(self, *arguments: Any, **keywords: Any) -> Any:
        check_arguments(self._label, self._accepted, arguments, keywords)
        return checked_result(self._label, self._function(*arguments, **keywords))

    def __repr__(self) -> str:
        return f"<sandbox function {self._label}>"


def checked_results(label: str, function: Callable[..., Any]) -> Callable[..., Any]:
    """A Python callable (`sum`, `pow`, `math.prod`) whose results pass the dtype check."""

    def call(*arguments: Any, **keywords: Any) -> Any:
        return checked_result(label, function(*arguments, **keywords))

    call.__name__ = call.__qualname__ = getattr(function, "__name__", label)
    return call


def _refused(label: str, name: str, allowed: frozenset[str]) -> AttributeError:
    if not allowed:
        return AttributeError(f"{label}.{name} is not available in the sandbox")
    offer = ", ".join(sorted(allowed, key=str.lower))
    return AttributeError(f"{label}.{name} is not available in the sandbox; {label} offers only: {offer}")


def numpy_label(value: Any) -> tuple[str, frozenset[str]] | None:
    """What a numpy value is called and which attributes it offers; None for non-numpy values."""
    if isinstance(value, numpy.ndarray):
        return "array", ARRAY_ATTRIBUTES
    if isinstance(value, numpy.generic):
        return "numpy scalar", ARRAY_ATTRIBUTES
    if isinstance(value, numpy.dtype):
        return "dtype", DTYPE_ATTRIBUTES
    if isinstance(value, CheckedCallable):
        return value._label, frozenset()  # a function: callable, nothing else
    if isinstance(value, type) and issubclass(value, numpy.generic | numpy.ndarray | numpy.dtype):
        return f"np.{value.__name__}", frozenset()  # a type: callable, nothing else
    return None


def attribute(value: Any, name: str) -> Any:
    """`value.name` as a program reads it (every attribute load of a program comes here)."""
    described = numpy_label(value)
    if described is None:
        return getattr(value, name)
    label, allowed = described
    if name not in allowed:
        raise _refused(label, name, allowed)
    checked_result(label, value)  # no member of an array that should not exist
    member = getattr(value, name)
    accepted = METHODS.get(name)
    return member if accepted is None else CheckedCallable(f"{label}.{name}", member, accepted)


def has_attribute(value: Any, name: str) -> bool:
    described = numpy_label(value)
    if described is not None:
        return name in described[1]
    return hasattr(value, name)
