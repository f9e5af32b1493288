"""The numpy surface a program may touch, as an allow-list decided in one place.

Every `x.name` a program reads is routed here by the validator's rewriter
(validation.ATTRIBUTE_FUNCTION_NAME), so for any numpy array, numpy scalar, dtype or numpy type the
program holds, wherever it came from (the restricted `np`, an API tool, a scalar method, an
operator), only the names below exist. The list holds read-only and arithmetic members only: no
method that changes a buffer in place or frees one (`resize`, `put`, `fill`, `sort`, `itemset`,
`setflags`, `byteswap`...), none that exposes raw memory (`view`, `data`, `base`, `ctypes`,
`tobytes`, `strides`...). `astype` converts only to numeric dtypes. Checking the name at the one
place every access passes through (rather than hunting bad methods one by one) also covers the
numpy scalars, which, unlike arrays, cannot be replaced by a restricted subclass.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy

ARRAY_ATTRIBUTES = frozenset(
    {
        # read-only facts
        "shape", "dtype", "ndim", "size", "itemsize", "T", "real", "imag",
        # new arrays or plain values
        "reshape", "copy", "astype", "transpose", "flatten", "ravel", "squeeze", "swapaxes",
        "diagonal", "nonzero", "repeat", "take", "conj", "conjugate", "tolist", "item",
        # arithmetic and reductions
        "sum", "mean", "std", "var", "prod", "min", "max", "argmin", "argmax", "argsort", "cumsum",
        "cumprod", "any", "all", "clip", "round", "dot", "trace",
    }
)  # fmt: skip
DTYPE_ATTRIBUTES = frozenset({"name", "kind", "itemsize", "char"})
NUMERIC_DTYPE_KINDS = "biufc"  # bool, signed, unsigned, float, complex
# Kinds no array of the program may have: object, raw records / structured, datetimes.
REFUSED_DTYPE_KINDS = "OVMm"


def _offer(names: frozenset[str]) -> str:
    return ", ".join(sorted(names, key=str.lower))


def numeric_dtype(dtype: Any) -> numpy.dtype:
    """`dtype` as a numpy dtype, if it is a numeric one; TypeError naming what is allowed if not."""
    try:
        resolved = numpy.dtype(dtype)
    except TypeError:
        raise TypeError(
            f"{dtype!r} is not a numpy dtype; use np.float64, np.int64, float, int or bool"
        ) from None
    if resolved.kind not in NUMERIC_DTYPE_KINDS:
        raise TypeError(
            f"astype({resolved}) is not available in the sandbox: arrays convert only to numeric dtypes "
            "(np.float64, np.float32, np.int64, np.int32, np.uint8, float, int, bool)"
        )
    return resolved


def _checked_astype(array: Any, dtype: Any, *arguments: Any, **keywords: Any) -> Any:
    return array.astype(numeric_dtype(dtype), *arguments, **keywords)


def _refused(label: str, name: str, allowed: frozenset[str]) -> AttributeError:
    if not allowed:
        return AttributeError(f"{label}.{name} is not available in the sandbox")
    return AttributeError(
        f"{label}.{name} is not available in the sandbox; {label} offers only: {_offer(allowed)}"
    )


def numpy_label(value: Any) -> tuple[str, frozenset[str]] | None:
    """What a numpy value is called and which attributes it offers; None for non-numpy values."""
    if isinstance(value, numpy.ndarray):
        return "array", ARRAY_ATTRIBUTES
    if isinstance(value, numpy.generic):
        return "numpy scalar", ARRAY_ATTRIBUTES
    if isinstance(value, numpy.dtype):
        return "dtype", DTYPE_ATTRIBUTES
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
    if name == "astype":
        return functools.partial(_checked_astype, value)
    return getattr(value, name)


def has_attribute(value: Any, name: str) -> bool:
    described = numpy_label(value)
    if described is not None:
        return name in described[1]
    return hasattr(value, name)
