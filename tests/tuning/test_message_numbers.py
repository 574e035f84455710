"""Numbers in the tuning layer's warnings and errors are written to the digits that count.

The issue: ``T < 3 T0 (20.0 < 55.349999999999994)`` in a warning of the inverse
half-rule (``3 * T0`` formatted with ``str``).  Hypothesis draws models whose
parameters have two decimals -- what a user types or a fit rounds to -- and
every warning and error of the rules and of the ADRC and PID tunings on them
must be free of such numbers (``tests/text_checks.py``).
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks.blocks.base import ParameterError
from ctrlblocks.tuning import adrc_tuning, amigo, inverse_half_rule, simc

from ..text_checks import long_floats

decimals = st.integers(min_value=1, max_value=9999).map(lambda n: n / 100.0)


def _messages(fn, *args, **kw) -> list[str]:
    try:
        out = fn(*args, **kw)
    except (ValueError, ParameterError) as exc:
        return [str(exc)]
    return [str(w) for w in getattr(out, "warnings", [])]


@given(k=decimals, T=decimals, T0=decimals, order=st.sampled_from([1, 2, 3]))
@settings(max_examples=300, deadline=None)
def test_half_rule_messages_have_no_float_with_all_its_digits(k, T, T0, order):
    for msg in _messages(inverse_half_rule, k, T, T0, order):
        assert long_floats(msg, allowed=[repr(k), repr(T), repr(T0)]) == [], msg


def test_the_issues_warning_gives_3_t0_to_four_digits():
    (msg,) = [m for m in _messages(inverse_half_rule, 1.0, 20.0, 18.45, 2) if "3 T0" in m]
    assert "55.35" in msg and "55.349999999999994" not in msg


@given(k=decimals, T=decimals, T0=decimals)
@settings(max_examples=200, deadline=None)
def test_pid_rule_messages_have_no_float_with_all_its_digits(k, T, T0):
    for msg in _messages(simc, k, T, T0) + _messages(amigo, k, T, T0):
        assert long_floats(msg, allowed=[repr(k), repr(T), repr(T0)]) == [], msg


def test_adrc_tuning_messages_have_no_float_with_all_its_digits():
    # models whose tunings warn (order 1 on a lag-and-delay process, a fragile ts, a
    # dead-time-dominant one); an ADRC tuning takes about a second
    models = [(0.73, 8.42, 2.88, 1, 0.1), (2.0, 30.0, 5.0, 2, 1.7),
              (1.31, 3.3, 3.29, 2, 0.05), (0.5, 12.5, 9.87, 3, 0.37)]  # fmt: skip
    for k, T, T0, order, ts in models:
        for msg in _messages(adrc_tuning, k, T, T0, order, ts=ts):
            assert long_floats(msg, allowed=[repr(k), repr(T), repr(T0), repr(ts)]) == [], msg
