"""The fault campaign: each injected fault is found, healthy loops raise no finding.

The default run assesses two loops of each kind; the campaign of docs/health.md
(``-m slow``) 50 of each, 300 loops, and checks the rates stated there.
"""

from __future__ import annotations

import pytest

from ctrlblocks.health.faults import EXPECTED, KINDS, assess_case, campaign, simulate


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", [0])
def test_each_fault_is_found_and_a_healthy_loop_raises_nothing(kind: str, seed: int) -> None:
    a = assess_case(simulate(kind, seed))
    found = {f.kind for f in a.findings}
    if EXPECTED[kind] is None:
        assert found == set(), [f.message for f in a.findings]
    else:
        assert EXPECTED[kind] in found, (a.figures(), a.notes)


def test_an_over_tuned_oscillation_is_not_called_stiction() -> None:
    for seed in (0, 1, 2):
        a = assess_case(simulate("oscillating", seed))
        assert a.horch is not None and a.horch.verdict == "no stiction"


def test_the_drift_re_identifies_the_true_gain() -> None:
    c = simulate("drift", 1)
    a = assess_case(c)
    assert a.drift["gain"] == pytest.approx(c.truth["true_gain"], rel=0.1)


def test_a_fault_case_is_reproducible_from_its_seed() -> None:
    a, b = simulate("stiction", 4), simulate("stiction", 4)
    assert (a.data.y == b.data.y).all() and a.truth == b.truth


WANT = {"healthy": 0, "stiction": 49, "oscillating": 47, "drift": 42, "manual": 50,
        "saturated": 50}
"""docs/health.md: loops of 50 with a finding (healthy) or the expected one (the faults)."""


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_campaign_rates_of_docs_health(kind: str) -> None:
    res = campaign(range(50), kinds=(kind,))
    print(kind, res.loops[kind], res.detected[kind], res.any_finding[kind], res.findings[kind])
    if kind == "healthy":
        assert res.any_finding["healthy"] == WANT["healthy"]
    else:
        assert res.detected[kind] >= WANT[kind] - 2, kind
