"""docs/error-codes.md and ErrorCode must list the same codes with the same names."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ctrlblocks import ErrorCode, ParameterError

DOC = Path(__file__).resolve().parents[2] / "docs" / "error-codes.md"


def _doc_table() -> dict[int, str]:
    rows = re.findall(r"^\| 16#([0-9A-F]{4}) \| (\w+) \|", DOC.read_text(), flags=re.M)
    return {int(code, 16): name for code, name in rows}


def test_doc_table_equals_the_enum() -> None:
    assert _doc_table() == {int(c): c.name for c in ErrorCode}


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("NO_CYCLE", 0x8001),
        ("BAD_LIMITS", 0x8201),
        ("CANT_TRACK_SETP", 0x8202),
        ("BAD_RATE", 0x8203),
        ("BACK_CALC_T", 0x8205),
        ("BAD_ANTIWINDUP", 0x8207),
        ("BAD_STAB_TIME", 0x8209),
        ("BAD_DEV_TOL", 0x820A),
        ("BAD_PID_COEFFS", 0x820B),
    ],
)
def test_seed_002_codes_keep_their_numbers(name: str, value: int) -> None:
    assert ErrorCode[name] == value


def test_parameter_error_is_a_value_error_naming_field_and_code() -> None:
    err = ParameterError(ErrorCode.BAD_RATE, "rate_up", "must be >= 0")
    assert isinstance(err, ValueError)
    assert err.code == 0x8203 and err.field == "rate_up"
    assert "16#8203" in str(err) and "rate_up" in str(err)
