"""Text crossing the sandbox boundary: always encodable as UTF-8.

A program can build strings holding lone surrogates ('\\ud800'); JSON carries them as escapes, but
encoding them for an HTTP response or a model prompt fails. Each one becomes U+FFFD.
"""

from __future__ import annotations

import re

_LONE_SURROGATE = re.compile("[\ud800-\udfff]")


def clean_text(text: object) -> str:
    """`text` as a str without lone surrogates (a non-str is converted with str first)."""
    value = text if isinstance(text, str) else str(text)
    return _LONE_SURROGATE.sub("\ufffd", value)


# CPython's default repr names an object's heap address ("<function f at 0x7f...>"); addresses
# are the first step of every memory attack, so text a program builds never shows them.
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")
ADDRESS_HIDDEN = " at (address hidden)"


def hide_addresses(text: str) -> str:
    return _ADDRESS.sub(ADDRESS_HIDDEN, text)
