"""Checks of text a user reads: no float written with all of its digits.

``55.349999999999994`` in a warning (``3 * T0`` formatted with ``str``) is the
class: a number the program computed, formatted with ``repr``/``str`` instead of
a format that says how many digits mean something.  :func:`long_floats` finds
such numbers in a text (more than 12 significant digits); the numbers a user
typed may come back as typed (``allowed``).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

NUMBER = re.compile(r"(?<![\w.])[-+]?(\d+\.\d+|\d+\.|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def significant_digits(token: str) -> int:
    mantissa = re.split(r"[eE]", token.lstrip("+-"))[0].replace(".", "")
    return len(mantissa.lstrip("0"))


def long_floats(text: str, allowed: Iterable[str] = ()) -> list[str]:
    """The numbers of ``text`` with a fraction and more than 12 significant digits."""
    ok = set(allowed)
    out = []
    for m in NUMBER.finditer(text):
        tok = m.group(0)
        if "." in tok and significant_digits(tok) > 12 and tok not in ok:
            out.append(tok)
    return out


def test_the_checker_finds_the_issues_number():
    assert long_floats("warning: T < 3 T0 (20.0 < 55.349999999999994)") == ["55.349999999999994"]
    assert long_floats("Ms 1.594, GM 2.76 (8.8 dB), 0.007301 rad/s, 1714564800500 ms") == []
    assert long_floats("got 0.1234567890123", allowed=["0.1234567890123"]) == []
