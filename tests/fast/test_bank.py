"""A bank of N loops equals N block loops run one by one (sample by sample, 1e-12)."""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks import PID
from ctrlblocks.fast import HAVE_NUMBA, PIDBank, UnsupportedConfig, reference_loop
from ctrlblocks.fast._jit import python_function
from ctrlblocks.fast.bank import _chain_zoh
from ctrlblocks.plants import PTn

ENGINES = ["python", *(["auto"] if HAVE_NUMBA else [])]
N_LOOPS = 13  # three groups of four and one loop alone
STEPS = 200


def _random_loops(seed: int = 3):
    rng = np.random.default_rng(seed)
    return dict(
        kp=rng.uniform(1.0, 6.0, N_LOOPS),
        ti=np.where(rng.random(N_LOOPS) < 0.2, 0.0, rng.uniform(2.0, 10.0, N_LOOPS)),
        td=rng.uniform(0.0, 2.0, N_LOOPS),
        k=rng.uniform(0.5, 1.5, N_LOOPS),
        t=rng.uniform(0.5, 5.0, (N_LOOPS, 3)),
        u_max=rng.uniform(1.2, 3.0, N_LOOPS),
    )


def _reference(p, j, sp, aw="clamping"):
    pid = PID(kp=p["kp"][j], ti=p["ti"][j], td=p["td"][j], ts=0.1, u_min=0.0,
              u_max=p["u_max"][j], anti_windup=aw)  # fmt: skip
    plant = PTn(k=p["k"][j], t=tuple(p["t"][j]), ts=0.1)
    r = reference_loop(pid, plant, np.full(STEPS, sp[j]))
    return plant.y, r.u[-1], float(np.sum(np.abs(sp[j] - r.y)) * 0.1)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(("aw", "parallel"), [("clamping", False), ("back_calc_model", False),
                                              ("clamping", True)])  # fmt: skip
def test_bank_from_arrays_equals_the_blocks_loop_by_loop(engine, aw, parallel):
    p = _random_loops()
    sp = np.linspace(0.5, 2.0, N_LOOPS)  # high setpoints saturate (anti-windup matters)
    bank = PIDBank.from_arrays(kp=p["kp"], ti=p["ti"], td=p["td"], ts=0.1, u_min=0.0,
                               u_max=p["u_max"], plant_k=p["k"], plant_t=p["t"],
                               anti_windup=aw)  # fmt: skip
    res = bank.run(sp, STEPS, engine=engine, parallel=parallel)
    for j in range(N_LOOPS):
        y, u, iae = _reference(p, j, sp, aw)
        assert res.y[j] == pytest.approx(y, abs=1e-12)
        assert res.u[j] == pytest.approx(u, abs=1e-12)
        assert res.iae[j] == pytest.approx(iae, abs=1e-9)
    assert np.any(res.u == p["u_max"])  # some loops end at their limit


@pytest.mark.parametrize("engine", ENGINES)
def test_bank_from_blocks_continues_their_state_and_can_be_run_in_pieces(engine):
    p = _random_loops(5)
    pids = [PID(kp=p["kp"][j], ti=p["ti"][j], td=p["td"][j], ts=0.1, u_min=0.0, u_max=3.0)
            for j in range(N_LOOPS)]  # fmt: skip
    plants = [PTn(k=p["k"][j], t=tuple(p["t"][j]), ts=0.1) for j in range(N_LOOPS)]
    for pid, plant in zip(pids, plants, strict=True):  # some history before the bank
        for _ in range(10):
            plant.step(pid(1.0, plant.y))
    bank = PIDBank(pids, plants)
    bank.run(1.0, 100, engine=engine)
    res = bank.run(1.0, 50, engine=engine)
    for pid, plant in zip(pids, plants, strict=True):
        reference_loop(pid, plant, np.full(150, 1.0))
    np.testing.assert_allclose(res.y, [pl.y for pl in plants], rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.u, [c.out for c in pids], rtol=0, atol=1e-12)


def test_bank_state_is_under_200_bytes_per_loop():
    bank = PIDBank.from_arrays(kp=1.0, ti=5.0, td=0.0, ts=0.1, plant_k=1.0,
                               plant_t=np.ones((4, 2)))  # fmt: skip
    assert bank.state_bytes == 80  # (i, d, w, e, out, cold) + (x0, x1, x2, y), float64
    assert bank.param_bytes == 224  # 13 PID + 15 plant floats


@pytest.mark.parametrize("m", [1, 2, 3])
@pytest.mark.parametrize("ts", [0.01, 0.1, 1.0])
@pytest.mark.parametrize("engine", ENGINES)
def test_bank_plant_rows_equal_the_linear_plants_exact_zoh(m, ts, engine):
    rng = np.random.default_rng(m)
    k = rng.uniform(0.1, 5.0, 40)
    t = rng.uniform(0.05, 20.0, (40, m))
    t[:8] = 2.0  # equal lags (a double pole)
    t[8:12, 0] = 0.01  # lags much shorter than the sample time: many squarings
    pp = np.empty((40, 15))
    fn = _chain_zoh if engine == "auto" else python_function(_chain_zoh)
    fn(pp, k, t, ts)
    for j in range(40):
        plant = PTn(k=k[j], t=tuple(t[j]), ts=ts)  # scipy.linalg.expm of the same matrix
        phi = np.zeros((3, 3))
        phi[:m, :m] = plant.phi
        want = np.r_[phi.ravel(), np.pad(plant.gamma0, (0, 3 - m)), np.pad(plant.c, (0, 3 - m))]
        np.testing.assert_allclose(pp[j], want, rtol=0, atol=1e-12)


def test_bank_refuses_dead_time_and_mixed_sample_times():
    with pytest.raises(UnsupportedConfig, match="dead time"):
        PIDBank([PID(kp=1.0, ts=0.1)], [PTn(k=1.0, t=(1.0,), ts=0.1, dead_time=0.2)])
    with pytest.raises(UnsupportedConfig, match="sample time"):
        PIDBank([PID(kp=1.0, ts=0.1)], [PTn(k=1.0, t=(1.0,), ts=0.2)])


@pytest.mark.parametrize("engine", ENGINES)
def test_adrc_bank_equals_the_blocks_loop_by_loop(engine):
    from ctrlblocks import ADRC
    from ctrlblocks.fast import ADRCBank

    rng = np.random.default_rng(11)
    specs = [
        dict(order=int(o), b0=float(b0), omega_c=float(wc), omega_o=float(4 * wc),
             u_min=0.0, u_max=float(hi), anti_windup=aw)
        for o, b0, wc, hi, aw in zip(
            rng.integers(1, 4, N_LOOPS), rng.uniform(0.05, 0.2, N_LOOPS),
            rng.uniform(0.3, 0.8, N_LOOPS), rng.uniform(1.5, 3.0, N_LOOPS),
            (["directional", "freeze", "off"] * N_LOOPS)[:N_LOOPS], strict=True)
    ]  # fmt: skip
    plants = lambda: [PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1) for _ in specs]  # noqa: E731
    bank = ADRCBank([ADRC(**s, ts=0.1) for s in specs], plants())
    res = bank.run(np.linspace(0.5, 2.0, N_LOOPS), STEPS, chunk=5, engine=engine)
    sp = np.linspace(0.5, 2.0, N_LOOPS)
    for j, (spec, plant) in enumerate(zip(specs, plants(), strict=True)):
        r = reference_loop(ADRC(**spec, ts=0.1), plant, np.full(STEPS, sp[j]))
        assert res.y[j] == pytest.approx(plant.y, abs=1e-12)
        assert res.u[j] == pytest.approx(r.u[-1], abs=1e-12)
    assert bank.state_bytes == 112  # 9 + the handover offset q, and 4 plant floats
    assert np.any(res.u == [s["u_max"] for s in specs])  # some loops end at their limit
