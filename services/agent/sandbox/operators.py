"""A program's two-operand operators, as the validator's rewriter routes them (child side).

`a + b` runs as `result(a + b, '+')`, `a % b` as `percent(a, b)`, `x += v` as
`x = in_place(x, v, '+=')` and `c[k] += v` as `in_place_item(c, k, v, '+=')` (c and k evaluated
once, as Python does). Two operands are where numpy turns a Python value into an array on its own
(`np.arange(3) + [0, 0, 10**30]` is an object array), so each result passes the numpy dtype check.
One-operand operators and comparisons need no check: negating or inverting a numeric array keeps
a numeric dtype, and comparisons make bools. Text made with `%` hides heap addresses.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from typing import Any

from services.agent.sandbox.numpy_surface import checked_result
from services.agent.sandbox.text import hide_addresses

IN_PLACE: dict[str, Callable[[Any, Any], Any]] = {
    "+=": operator.iadd,
    "-=": operator.isub,
    "*=": operator.imul,
    "@=": operator.imatmul,
    "/=": operator.itruediv,
    "//=": operator.ifloordiv,
    "%=": operator.imod,
    "**=": operator.ipow,
    "<<=": operator.ilshift,
    ">>=": operator.irshift,
    "|=": operator.ior,
    "^=": operator.ixor,
    "&=": operator.iand,
}


# Results that cannot be numpy values: checked by their exact type, the cheap path of every loop.
_PYTHON_VALUES = frozenset({int, float, bool, complex, str, bytes, list, tuple, dict, set, frozenset})


def result(value: Any, symbol: str) -> Any:
    """The value of `left symbol right`, unless it is a numpy array of a refused dtype."""
    if type(value) in _PYTHON_VALUES:
        return value
    return checked_result(f"'{symbol}'", value)


def percent(left: Any, right: Any) -> Any:
    """`left % right`; for text formatting, the result hides addresses."""
    value = left % right
    return hide_addresses(value) if isinstance(value, str) else result(value, "%")


def in_place(target: Any, value: Any, symbol: str) -> Any:
    """`target symbol value` as an augmented assignment computes it (in place where the type can)."""
    updated = IN_PLACE[symbol](target, value)
    if type(updated) in _PYTHON_VALUES:  # the cheap path, inlined: loops of `total += x`
        return hide_addresses(updated) if symbol == "%=" and isinstance(updated, str) else updated
    return checked_result(f"'{symbol}'", updated)


def in_place_item(container: Any, key: Any, value: Any, symbol: str) -> None:
    """`container[key] symbol value`, each operand evaluated once."""
    container[key] = in_place(container[key], value, symbol)
