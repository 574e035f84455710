"""No computed float reaches a message unformatted: the static half of the sweep.

``f"T < 3 T0 ({T} < {3 * T0})"`` printed ``55.349999999999994``.  A product
written into an f-string without a format spec is a computed float printed with
all its digits; this test finds every such field in the package (the dynamic
half -- messages of the tuning rules under hypothesis, everything the CLI
prints in the number campaign -- is ``tests/tuning/test_message_numbers.py`` and
``tests/test_cli_number_campaign.py``).
"""

from __future__ import annotations

import ast
from pathlib import Path

from .text_checks import long_floats

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "ctrlblocks"


def unformatted_products() -> list[str]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.JoinedStr):
                continue
            for v in node.values:
                if not isinstance(v, ast.FormattedValue) or v.format_spec is not None:
                    continue
                if any(isinstance(x, ast.BinOp) and isinstance(x.op, ast.Mult)
                       for x in ast.walk(v.value)):  # fmt: skip
                    rel = path.relative_to(PACKAGE.parent)
                    out.append(f"{rel}:{node.lineno}: {{{ast.unparse(v.value)}}}")
    return out


def test_no_product_is_written_into_an_f_string_without_a_format():
    assert unformatted_products() == []


def test_the_checker_finds_the_issues_number():
    assert long_floats("warning: T < 3 T0 (20.0 < 55.349999999999994)") == ["55.349999999999994"]
    assert long_floats("Ms 1.594, GM 2.76 (8.8 dB), 0.007301 rad/s, 1714564800500 ms") == []
    assert long_floats("got 0.1234567890123", allowed=["0.1234567890123"]) == []
