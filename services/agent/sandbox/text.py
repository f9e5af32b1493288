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
