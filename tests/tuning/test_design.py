"""The one design path (ctrlblocks.tuning.design): every number against an independent oracle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.blocks.adrc import ADRC
from ctrlblocks.blocks.pid import PID
from ctrlblocks.plants.linear import FOPDT as PlantFOPDT
from ctrlblocks.plants.linear import PT2
from ctrlblocks.tuning.design import _Model, default_ts, design_adrc, design_pid, mv_noise_gain
from ctrlblocks.tuning.identify import FOPDT, SOPDT
from ctrlblocks.tuning.margins import DiscreteSS, Loop, controller_ss, smith_ss
from ctrlblocks.tuning.select import select_model
from tests.sim.brute_force import Oracle, response
from tests.sim.brute_force import mv_noise_gain as lyapunov_noise_gain

UNL = {"u_min": -math.inf, "u_max": math.inf}
MODEL = FOPDT(1.5, 20.0, 4.0)
TS = 0.2


def _plant(model, ts):
    if isinstance(model, SOPDT):
        return PT2(model.gain, model.time_constant, model.time_constant_2, ts, model.dead_time)
    return PlantFOPDT(model.gain, model.time_constant, model.dead_time, ts)


BLOCKS = [
    ("PI", lambda: PID(kp=1.2, ti=15.0, ts=TS, **UNL), False),
    ("PID", lambda: PID(kp=1.5, ti=12.0, td=2.0, n=5.0, b=0.6, ts=TS, **UNL), False),
    ("ADRC n=2", lambda: ADRC(order=2, b0=0.05, omega_c=0.25, omega_o=1.0, ts=TS, **UNL), False),
    ("ADRC delayed",
     lambda: ADRC(order=1, b0=0.1, omega_c=0.2, omega_o=0.8, ts=TS, input_delay=4.0, **UNL),
     False),
    ("PI + Smith", lambda: PID(kp=2.0, ti=12.0, ts=TS, **UNL), True),
]


@pytest.mark.parametrize(("name", "make", "smith"), BLOCKS, ids=[b[0] for b in BLOCKS])
def test_the_fft_load_and_setpoint_iae_equal_the_loop_simulated_in_time(name, make, smith):
    m = _Model(MODEL, TS, smith)
    ss = controller_ss(make())
    lp = Loop(MODEL, smith_ss(ss, MODEL) if smith else ss)
    y_load = response(lp, 400.0, load=1.0)
    y_sp = response(lp, 400.0, r=1.0)
    assert abs(y_load[-1]) < 1e-6 and abs(1.0 - y_sp[-1]) < 1e-6  # settled: a fair window
    assert m.load_iae(m.cy(ss)) == pytest.approx(np.sum(np.abs(y_load)) * TS, rel=1e-6)
    assert m.setpoint_iae(ss) == pytest.approx(np.sum(np.abs(1.0 - y_sp)) * TS, rel=1e-5)


@pytest.mark.parametrize(("name", "make", "smith"), BLOCKS, ids=[b[0] for b in BLOCKS])
def test_the_mv_noise_formula_equals_the_lyapunov_equation_and_a_simulation(name, make, smith):
    """Parseval on the grid against the closed loop's Lyapunov equation (exact), and a
    simulation of the real block on the real plant with seeded white PV noise."""
    block = make()
    gain = mv_noise_gain(MODEL, block, smith=smith)
    ss = controller_ss(block)
    exact = lyapunov_noise_gain(Loop(MODEL, smith_ss(ss, MODEL) if smith else ss))
    assert gain == pytest.approx(exact, rel=2e-3)
    if smith:
        return
    plant = _plant(MODEL, TS)
    sim = make()
    rng = np.random.default_rng(4)
    us = []
    for e in rng.normal(0.0, 1.0, 40000):
        u = sim(0.0, plant.y + float(e))
        plant.step(u)
        us.append(u)
    assert float(np.std(us[2000:])) == pytest.approx(exact, rel=0.03)


def test_the_smith_loop_equals_the_simulators_structure():
    """smith_ss: the linear loop equals the simulator's Smith predictor (models stepped with
    the block's u after the block read y + M0 - M) with the real block and plants."""
    ts = 0.1
    lp = Loop(MODEL, smith_ss(controller_ss(PID(kp=2.0, ti=12.0, ts=ts, **UNL)), MODEL))
    t, y, _u = lp.simulate(150.0, r=1.0, load=0.2)
    block = PID(kp=2.0, ti=12.0, ts=ts, **UNL)
    plant, model, fast = _plant(MODEL, ts), _plant(MODEL, ts), PlantFOPDT(1.5, 20.0, 0.0, ts)
    block(0.0, 0.0)  # leave the block's first-cycle start-up, as controller_ss does
    block(0.0, 0.0)
    ys = []
    for _ in t:
        ys.append(plant.y)
        u = block(1.0, plant.y + fast.y - model.y)
        plant.step(u + 0.2)
        model.step(u)
        fast.step(u)
    assert np.max(np.abs(np.array(ys) - y)) < 1e-9


@pytest.mark.parametrize("order", [1, 2, 3])
def test_a_delayed_adrc_read_from_a_one_sample_probe_equals_reading_every_state(order):
    blk = ADRC(order=order, b0=0.7, omega_c=0.5, omega_o=2.0, ts=0.1, input_delay=1.3)
    a, b = controller_ss(blk), controller_ss(blk, direct=True)
    for x, z in ((a.a, b.a), (a.b, b.b), (a.c, b.c), (a.d, b.d)):
        assert np.array_equal(x, z)
    w = math.pi / 0.1 * np.logspace(-4, 0, 200)
    full = DiscreteSS(b.a, b.b, b.c, b.d, b.ts)
    assert np.allclose(a.response(w), full.response(w), rtol=1e-9, atol=0)


def test_the_delayed_adrc_loop_equals_the_real_block_on_the_real_plant():
    m = FOPDT(1.0, 1.0, 3.0)
    ts = 0.05

    def make():
        return ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=ts, input_delay=3.0, **UNL)

    t, y, _u = Loop(m, make()).simulate(60.0, r=0.0, load=1.0)
    block, plant = make(), PlantFOPDT(1.0, 1.0, 3.0, ts)
    ys = []
    for _ in t:
        ys.append(plant.y)
        plant.step(block(0.0, plant.y) + 1.0)
    assert np.max(np.abs(np.array(ys) - y)) < 1e-12


PID_KINDS = {"pi": {"controller": "pi"}, "pid": {},
             "pid noise": {"noise_std": 0.02, "mv_noise_max": 0.05}}  # fmt: skip


@pytest.fixture(scope="module")
def designs():
    """The designs on MODEL, each made once for the module's tests: the PID kinds, the ADRC n=2
    and both on the reverse-acting process."""
    neg = FOPDT(-1.5, 20.0, 4.0)
    out = {kind: design_pid(MODEL, TS, **kw) for kind, kw in PID_KINDS.items()}
    out["adrc"] = design_adrc(MODEL, 2, TS)
    out["pid reverse"], out["adrc reverse"] = design_pid(neg, TS), design_adrc(neg, 2, TS)
    return out


@pytest.mark.parametrize("kind", list(PID_KINDS))
def test_the_pid_design_keeps_ms_and_the_noise(kind, designs):
    """Ms within the target, the MV noise (Lyapunov) within the budget."""
    d, kw = designs[kind], PID_KINDS[kind]
    assert d.margins.stable and d.margins.ms <= 1.6 * 1.001
    if "noise_std" in kw:
        assert lyapunov_noise_gain(d.loop(MODEL)) * kw["noise_std"] <= kw["mv_noise_max"] * 1.01


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(PID_KINDS))
def test_a_brute_force_grid_finds_no_pid_better_than_the_design(kind, designs):
    """A plain grid on the same model (the tests' oracle), at the same Ms and noise budget,
    finds no PI/PID with a load IAE 3 % better."""
    d, kw = designs[kind], PID_KINDS[kind]
    o = Oracle(MODEL, TS, 1.6, kw.get("noise_std", 0.0), kw.get("mv_noise_max", math.inf),
               1.0, 1.0)  # fmt: skip
    own = o.iae(d.loop(MODEL), "load")
    best = math.inf
    tds = [0.0] if kind == "pi" else [0.0, 1.0, 2.0, 3.0]
    for td in tds:
        for n in ([10.0] if td == 0.0 else [2.5, 5.0, 10.0]):
            for kp in np.geomspace(0.3, 4.0, 12):
                for ti in np.geomspace(3.0, 40.0, 12):
                    cand = o.admissible(PID(kp=kp, ti=ti, td=td, n=n, ts=TS, **UNL), False)
                    if cand is not None:
                        best = min(best, o.iae(cand, "load"))
    assert own <= 1.03 * best, (own, best)


def test_the_adrc_design_keeps_ms_and_searches_the_observer_ratio(designs):
    d = designs["adrc"]
    assert d.margins.stable and 1.6 * 0.98 <= d.margins.ms <= 1.6 * 1.001
    ratio = d.params["omega_o"] / d.params["omega_c"]
    assert any(math.isclose(ratio, r, rel_tol=1e-9) for r in (3.0, 5.0, 10.0))


@pytest.mark.slow
def test_a_brute_force_grid_finds_no_adrc_better_than_the_design(designs):
    o = Oracle(MODEL, TS, 1.6, 0.0, math.inf, 1.0, 1.0)
    own = o.iae(designs["adrc"].loop(MODEL), "load")
    best = math.inf
    for b0 in 1.5 / 24**2 * np.geomspace(1.0, 300.0, 10):
        for wc in np.geomspace(0.03, 1.0 / 3.0, 10):
            for r in (3.0, 5.0, 10.0):
                if r * wc * TS > 0.2:
                    continue
                lp = o.admissible(ADRC(order=2, b0=b0, omega_c=wc, omega_o=r * wc, ts=TS, **UNL),
                                  False)  # fmt: skip
                if lp is not None:
                    best = min(best, o.iae(lp, "load"))
    assert own <= 1.05 * best, (own, best)


def test_a_reverse_acting_process_gets_the_mirrored_designs_with_reverse(designs):
    for family in ("pid", "adrc"):
        d, mirror = designs[f"{family} reverse"], designs[family]
        params = dict(d.params)
        assert params.pop("reverse") is True
        assert params == mirror.params and d.ki == pytest.approx(-mirror.ki)
        assert d.margins.ms == pytest.approx(mirror.margins.ms, rel=1e-12)


@pytest.mark.slow
def test_on_a_dead_time_dominant_process_both_compensated_candidates_beat_the_plain_ones():
    """At the same Ms on the model: PI in a Smith predictor against PI, and the ADRC whose
    observer is fed the MV delayed by the dead time against the plain ADRC of that order."""
    m = FOPDT(1.0, 4.0, 12.0)
    ts = default_ts(4.0, 12.0)
    pi, smith = design_pid(m, ts, controller="pi"), design_pid(m, ts, controller="pi", smith=True)
    a1, a1d = design_adrc(m, 1, ts), design_adrc(m, 1, ts, input_delay=12.0)
    for d in (pi, smith, a1, a1d):
        assert d.margins.stable and d.margins.ms <= 1.6 * 1.001
    assert smith.load_iae(m) < 0.95 * pi.load_iae(m)
    assert a1d.load_iae(m) < 0.95 * a1.load_iae(m)


def test_the_bic_chooses_the_sopdt_where_the_former_fit_ratio_rule_could_not():
    """A noisy bump test of an SOPDT with T2/T1 = 0.4: both fit errors are mostly the noise
    (their ratio above 0.8, the former rule's threshold), the BIC still sees the second lag;
    a noisy FOPDT keeps the FOPDT."""
    from tests.sim.processes import Process

    t, u, y = Process("sopdt", SOPDT(1.0, 10.0, 1.0, 4.0), 0.03, 9).bump()
    c = select_model(t, u, y)
    assert c.sopdt.fit > 0.8 * c.fopdt.fit
    assert c.model is c.sopdt and "BIC" in c.why
    t, u, y = Process("fopdt", FOPDT(1.0, 10.0, 3.0), 0.03, 9).bump()
    assert select_model(t, u, y).model.as_dict()["model"] == "fopdt"
