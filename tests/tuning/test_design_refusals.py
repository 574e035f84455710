"""The design searches refuse what they cannot size, with an error code, before any grid is built.

Found by the CLI's hostile-number campaign (tests/test_cli_number_campaign.py):
``tune adrc --time-constant 1e308`` overflowed the load response's FFT length
(OverflowError) and ``--observer-ratio 0`` divided by zero in the omega_c
search.  The class: a model or ratio outside what the grids are sized for.
Both design functions share the checks, so they are tested on both.
"""

from __future__ import annotations

import math

import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.plants.linear import MAX_DEAD_SAMPLES
from ctrlblocks.tuning.design import design_adrc, design_pid
from ctrlblocks.tuning.identify import FOPDT, SOPDT


def _designs(model, ts, **kw):
    yield lambda: design_pid(model, ts, **kw)
    yield lambda: design_adrc(model, 2, ts, **kw)


@pytest.mark.parametrize(
    "model",
    [FOPDT(1.0, 1e308, 1.0), FOPDT(1.0, 1.0, 1e308), SOPDT(1.0, 5.0, 1.0, 1e300),
     FOPDT(1.0, 0.1 * (MAX_DEAD_SAMPLES + 10), 0.0)],
)  # fmt: skip
def test_a_model_slower_than_a_million_samples_is_refused_as_a_time_constant(model):
    for design in _designs(model, 0.1):
        with pytest.raises(ParameterError) as err:
            design()
        assert err.value.code == ErrorCode.BAD_TIME_CONSTANT


@pytest.mark.parametrize("ts", [0.0, -1.0, math.nan, math.inf])
def test_a_sample_time_that_is_not_finite_and_positive_is_refused(ts):
    for design in _designs(FOPDT(1.0, 5.0, 1.0), ts):
        with pytest.raises(ParameterError) as err:
            design()
        assert err.value.code == ErrorCode.BAD_TIME_CONSTANT


@pytest.mark.parametrize("ratio", [0.0, 1e-320, 0.5, -3.0, math.nan, math.inf, 1e308])
def test_an_observer_ratio_outside_1_to_100_is_refused_as_a_bandwidth(ratio):
    with pytest.raises(ParameterError) as err:
        design_adrc(FOPDT(1.0, 5.0, 1.0), 2, 0.1, ratios=(3.0, ratio))
    assert err.value.code == ErrorCode.BAD_BANDWIDTH
    assert "observer_ratio" in str(err.value)


@pytest.mark.parametrize("gain", [1e308, -1e308, 1e31, 1e-31, 1e-300, 5e-324])
def test_a_process_gain_beyond_1e30_either_way_is_refused_as_a_parameter(gain):
    # tune pid --gain 1e308 (the designed PID, not the rule the CLI campaign drove)
    # divided by zero in the kp search; tune adrc overflowed the load response's FFT
    # with RuntimeWarnings on the user's screen
    import warnings

    for design in _designs(FOPDT(gain, 5.0, 1.0), 0.1):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(ParameterError) as err:
                design()
        assert err.value.code == ErrorCode.BAD_PARAMETER and err.value.field == "gain"


@pytest.mark.parametrize("decade", [-9, -3, 3, 6])
def test_the_designs_scale_with_the_process_gain(decade):
    # the loop is the same when the gain is k times and the controller's 1/k: kp k,
    # b0/k, omega_c and the margins do not depend on the gain's units
    one = FOPDT(1.0, 5.0, 1.0)
    k = 10.0**decade
    scaled = FOPDT(k, 5.0, 1.0)
    pid1, pidk = design_pid(one, 0.1), design_pid(scaled, 0.1)
    assert pidk.params["kp"] * k == pytest.approx(pid1.params["kp"], rel=1e-9)
    assert pidk.margins.ms == pytest.approx(pid1.margins.ms, rel=1e-9)
    adrc1, adrck = design_adrc(one, 2, 0.1), design_adrc(scaled, 2, 0.1)
    assert adrck.params["b0"] / k == pytest.approx(adrc1.params["b0"], rel=1e-9)
    assert adrck.params["omega_c"] == pytest.approx(adrc1.params["omega_c"], rel=1e-9)
