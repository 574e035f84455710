"""The transfer-function block and its designs against scipy.signal."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from ctrlblocks import ErrorCode, ParameterError, TransferFunction
from ctrlblocks.blocks.transfer import dc_gain, frequency_response, lowpass, notch, tustin

TS = 0.1
FS = 1.0 / TS


def _freqs(ts: float) -> np.ndarray:
    return np.linspace(1e-3, 0.999 * math.pi / ts, 200)


@pytest.mark.parametrize("order", range(1, 9))
def test_lowpass_is_scipys_butterworth(order: int) -> None:
    w = 2.0  # rad/s
    sos = lowpass(w, TS, order)
    ref = signal.butter(order, w / (2 * math.pi), fs=FS, output="sos")
    ws = _freqs(TS)
    _, h_ref = signal.sosfreqz(ref, worN=ws, fs=2 * math.pi * FS)
    h = np.array([frequency_response(sos, x, TS) for x in ws])
    np.testing.assert_allclose(h, h_ref, rtol=0, atol=1e-12)
    # the hand values: |H| = 1/sqrt(2) at the cut-off, DC gain 1
    assert abs(frequency_response(sos, w, TS)) == pytest.approx(2**-0.5, abs=1e-13)
    assert dc_gain(sos) == pytest.approx(1.0, abs=1e-13)


@pytest.mark.parametrize("depth", [0.0, 0.1, 0.5])
def test_notch_is_the_prewarped_bilinear_image_of_the_analog_notch(depth: float) -> None:
    w, q, ts = 5.0, 2.0, 0.01
    wa = 2.0 / ts * math.tan(w * ts / 2.0)  # prewarped
    b, a = signal.bilinear([1.0, 2.0 * depth / (2.0 * q) * wa, wa**2], [1.0, wa / q, wa**2], 1 / ts)
    sec = notch(w, q, ts, depth)
    np.testing.assert_allclose(sec, [*b, *a[1:]], rtol=0, atol=1e-13)
    # the gain left at the notch frequency is the depth; 1 at DC and at Nyquist
    assert abs(frequency_response([sec], w, ts)) == pytest.approx(depth, abs=1e-12)
    assert dc_gain([notch(w, q, ts, depth)]) == pytest.approx(1.0, abs=1e-13)


def test_full_notch_with_depth_zero_is_bristow_johnsons_cookbook_notch() -> None:
    w, q, ts = 3.0, 5.0, 0.05
    w0 = w * ts
    alpha = math.sin(w0) / (2 * q)
    ref = np.array([1, -2 * math.cos(w0), 1, -2 * math.cos(w0), 1 - alpha]) / (1 + alpha)
    np.testing.assert_allclose(notch(w, q, ts), ref, rtol=0, atol=1e-14)


def test_tustin_of_a_second_order_system_matches_scipy_bilinear() -> None:
    num, den = [2.0, 3.0], [1.0, 0.8, 4.0]
    b, a = signal.bilinear(num, den, FS)
    b = np.r_[np.zeros(3 - len(b)), b]
    np.testing.assert_allclose(tustin(num, den, TS), [*b, *a[1:]], rtol=0, atol=1e-14)
    # first order: one pole, no pole-zero pair at z = -1
    b1, a1 = signal.bilinear([3.0], [1.0, 1.0], FS)
    np.testing.assert_allclose(tustin([3.0], [1.0, 1.0], TS), [*b1, 0.0, a1[1], 0.0], atol=1e-14)
    # prewarped at 2 rad/s: the response there equals the analog one
    sec = tustin(num, den, TS, w_warp=2.0)
    analog = complex(np.polyval(num, 2j) / np.polyval(den, 2j))
    assert frequency_response([sec], 2.0, TS) == pytest.approx(analog, abs=1e-12)


def test_block_output_equals_scipy_sosfilt() -> None:
    sos = lowpass(1.0, TS, order=5)
    x = np.random.default_rng(1).normal(size=500)
    ref = signal.sosfilt(np.c_[np.array(sos)[:, :3], np.ones(len(sos)), np.array(sos)[:, 3:]], x)
    tf = TransferFunction(sections=sos, ts=TS)
    np.testing.assert_allclose([tf(v) for v in x], ref, rtol=0, atol=1e-12)


def test_float32_lane_stays_within_single_precision_of_float64() -> None:
    sos = lowpass(1.0, TS, order=4)
    x = np.random.default_rng(2).normal(size=500)
    a = TransferFunction(sections=sos, ts=TS)
    b = TransferFunction(sections=sos, ts=TS, precision="float32")
    ya = np.array([a(v) for v in x])
    yb = np.array([b(v) for v in x])
    assert np.max(np.abs(ya - yb)) < 1e-5
    assert np.max(np.abs(ya - yb)) > 0.0  # they do round differently


def test_init_starts_at_rest_at_the_input() -> None:
    tf = TransferFunction(sections=(*lowpass(1.0, TS, 3), tustin([3.0], [1.0, 1.0], TS)), ts=TS)
    first = tf(2.0, init=True)
    assert first == pytest.approx(2.0 * 3.0, abs=1e-12)  # DC gain 3
    assert all(tf(2.0) == pytest.approx(6.0, abs=1e-12) for _ in range(50))


def test_output_limits_limit_the_output_not_the_sections() -> None:
    tf = TransferFunction(sections=lowpass(1.0, TS, 1), ts=TS, out_min=-1.0, out_max=1.0)
    free = TransferFunction(sections=lowpass(1.0, TS, 1), ts=TS)
    for _ in range(100):
        tf(5.0), free(5.0)
    assert tf.out == 1.0
    assert tf.y == pytest.approx(free.out, abs=0)


def test_bad_input_holds_and_an_overflow_restarts_from_rest() -> None:
    tf = TransferFunction(sections=(tustin([1e3], [1.0, 1.0], TS), *lowpass(1.0, TS, 2)), ts=TS)
    y = tf(1.0)
    assert tf(math.nan) == y and tf.error_id == ErrorCode.BAD_INPUT
    assert tf(3e38) == y  # an input inside the REAL range whose memory (x 1000) is not
    assert tf.error_id == ErrorCode.BAD_RESULT
    snap = tf.snapshot()["_mem"]
    assert snap["z1"] == [0.0, 0.0] and snap["z2"] == [0.0, 0.0]
    tf(1.0)
    assert tf.error_id == ErrorCode.NO_ERROR


@pytest.mark.parametrize("section", [(1.0, 0.0, 0.0, 0.0, 1.0),  # poles on the unit circle
                                     (1.0, 0.0, 0.0, -2.1, 1.05),  # outside
                                     (1.0, 0.0, 0.0, -1.0, 0.0)])  # z = 1: an integrator
def test_unstable_sections_are_refused(section: tuple[float, ...]) -> None:
    with pytest.raises(ParameterError) as e:
        TransferFunction(sections=(section,))
    assert e.value.code == ErrorCode.BAD_PARAMETER


def test_design_helpers_refuse_frequencies_beyond_nyquist() -> None:
    with pytest.raises(ParameterError):
        lowpass(40.0, TS)  # pi/ts = 31.4 rad/s
    with pytest.raises(ParameterError):
        notch(5.0, 2.0, TS, depth=1.0)
