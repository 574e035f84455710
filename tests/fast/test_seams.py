"""The blocks' and plants' public seams for compiled paths, and the absence of private reads.

``kernel_params()`` / ``kernel_state()`` / ``load_kernel_state()`` and one
``fast_path_blockers()`` decision per block; ``ThreeTank.discrete_model()``.
The kernels run exactly what the seams give: a block continued from
``load_kernel_state`` after kernel cycles equals a block that ran them itself.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.adrc import ADRCKernelParams, ADRCKernelState, adrc_step
from ctrlblocks.blocks.pid import PIDKernelParams, PIDKernelState, pid_step
from ctrlblocks.fast.kernels import (
    ADRC_PARAMS,
    PID_PARAMS,
    UnsupportedConfig,
    adrc_params,
    pid_params,
)
from ctrlblocks.plants import ThreeTank

SRC = Path(__file__).resolve().parents[2] / "src" / "ctrlblocks"


def test_parameter_names_are_the_named_tuples_fields():
    assert PID_PARAMS == ("k", "sgn", "b", "c", "ad", "bd", "ki_h", "alpha", "beta",
                          "lo", "hi", "aw", "g")  # fmt: skip
    assert PIDKernelParams._fields == PID_PARAMS and ADRCKernelParams._fields == ADRC_PARAMS
    assert len(ADRC_PARAMS) == 24  # with a_q (handover) and nsub (Euler sub-steps)


def test_pid_kernel_params_are_the_isa_numbers():
    pid = PID(kp=2.0, ti=4.0, td=1.0, n=10.0, ts=0.1, u_min=-5.0, u_max=5.0)
    p = pid.kernel_params()
    assert isinstance(p, PIDKernelParams) and pid_params(pid) == tuple(p)
    tf = 1.0 / 10.0  # Td / N
    assert p.k == 2.0 and p.sgn == 1.0
    assert p.ad == pytest.approx(tf / (tf + 0.1))  # backward difference, Åström 1987 (2.11)
    assert p.bd == pytest.approx(2.0 * 1.0 / (tf + 0.1))
    assert p.ki_h == pytest.approx(2.0 * 0.1 / 4.0)
    assert (p.alpha, p.beta) == (0.5, 0.5)  # Tustin
    assert (p.lo, p.hi) == (-5.0, 5.0)


def _pid():
    return PID(kp=2.0, ti=4.0, td=0.5, ts=0.1, u_min=-3.0, u_max=3.0)


@pytest.mark.parametrize("n_kernel", [1, 25])
def test_pid_continues_exactly_after_kernel_cycles_through_load_kernel_state(n_kernel):
    ref, blk = _pid(), _pid()
    for k in range(5):
        ref(1.0, 0.1 * k)
        blk(1.0, 0.1 * k)
    prm = blk.kernel_params()
    st = blk.kernel_state()
    assert isinstance(st, PIDKernelState) and not st.cold and not st.manual
    i, d, w, e, out = st.i, st.d, st.w_prev, st.e_prev, st.out
    for k in range(n_kernel):
        pv = 0.3 + 0.05 * k
        ref(1.0, pv)
        out, _v, _p, _is, i, d, w, e = pid_step(
            1.0, pv, 0.0, False, 0.0, False, False, i, d, w, e, out, prm
        )
    blk.load_kernel_state(PIDKernelState(i, d, w, e, out, False, False, False))
    assert blk.out == ref.out
    for k in range(20):
        assert blk(1.0, 0.9 - 0.02 * k) == ref(1.0, 0.9 - 0.02 * k)


def test_adrc_continues_exactly_after_kernel_cycles_through_load_kernel_state():
    def make():
        return ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)

    ref, blk = make(), make()
    for k in range(5):
        ref(1.0, 0.1 * k)
        blk(1.0, 0.1 * k)
    prm = blk.kernel_params()
    s = blk.kernel_state()
    assert isinstance(s, ADRCKernelState) and s.started
    state = list(s)
    for k in range(10):
        y = 0.5 + 0.01 * k
        ref(1.0, y)
        u, _raw, yh, x2, x3, x4, r, q, track, sat = adrc_step(
            1.0, y, False, 0.0, state[6], state[7], state[8], *state[:5], state[5], state[9],
            prm,
        )
        state = [yh, x2, x3, x4, u, r, True, track, sat, q]
    blk.load_kernel_state(ADRCKernelState(*state))
    for k in range(20):
        assert blk(1.0, 0.6 - 0.01 * k) == ref(1.0, 0.6 - 0.01 * k)


def test_one_fast_path_decision_names_every_blocker():
    pid = PID(kp=1.0, ti=2.0, ts=0.1, sp_filter=1.0)
    assert pid.fast_path_blockers() == ["sp_filter"] and not pid.fast_path_supported()
    pid = PID(kp=1.0, ti=2.0, ts=0.1)
    assert pid.fast_path_supported()
    pid.track = True
    assert pid.fast_path_blockers() == ["track"]
    with pytest.raises(UnsupportedConfig, match="track"):
        pid_params(pid)
    pid.track = False
    pid.manual = True
    pid(1.0, 0.0)  # a cycle in manual
    assert pid.fast_path_supported() and not pid.fast_path_supported(manual_ok=False)
    adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, discretisation="exact")
    assert adrc.fast_path_blockers() == ["discretisation"]
    adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1)
    adrc.awin, adrc.manual = True, True
    assert adrc.fast_path_blockers(manual_ok=False) == ["awin", "manual"]
    with pytest.raises(UnsupportedConfig, match="awin"):
        adrc_params(adrc)


def test_threetank_discrete_model_matches_its_own_step():
    plant = ThreeTank(ts=0.5)
    plant.reset(1.0)
    m = plant.discrete_model()
    assert m.h == 0.5 / plant.substeps and len(m.g) == 6
    assert m.outlet_g[plant.outlet] == m.g[5] and len(m.outlet_g) == len(plant.outlets)
    from ctrlblocks.plants.threetank import P_ATM, threetank_rk4

    p = plant.snapshot()["p"]
    want = threetank_rk4(*p, 1.5 + P_ATM, m.g, m.h, m.substeps)
    plant.step(1.5)
    assert plant.snapshot()["p"] == pytest.approx(want, rel=0, abs=0)
    assert math.isfinite(plant.y)


def test_no_module_outside_the_blocks_reads_private_attributes_of_another_object():
    allowed = {
        ("fast/bank.py", "_init"),  # the bank class's own initialiser, from its classmethod
        ("fast/_jit.py", "_cache"),  # numba's dispatcher internals (the disk cache)
        ("fast/_jit.py", "_CacheLocator"),
    }
    found = set()
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith(("blocks/", "plants/")):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Attribute) or not node.attr.startswith("_"):
                continue
            if node.attr.startswith("__") or node.attr == "_fields":  # dunder, NamedTuple API
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            found.add((rel, node.attr))
    assert found <= allowed, sorted(found - allowed)
