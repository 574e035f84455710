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
