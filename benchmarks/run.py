"""ctrlblocks against the peers a user would pick instead, side by side in one run.

Usage (from the repository root, with the ``bench`` extra installed:
``pip install -e '.[bench]'``)::

    python benchmarks/run.py            # full run, about a minute
    python benchmarks/run.py --quick    # fewer repeats, about 30 s
    python benchmarks/run.py --markdown docs/performance-table.md
    python benchmarks/run.py --readme   # only the README's table, printed as it stands there
    python benchmarks/run.py --readme --update README.md   # ... and written into README.md

Timings on a shared machine jump between levels, so every comparison runs
both sides *interleaved* (A, B, A, B, ...) and reports the ratio of the
minima and the ratio of the medians (issue 6).  The C references
(``benchmarks/c/*.c``) are compiled here with the system compiler
(``cc -O2``) into a temporary folder; nothing binary is kept.

Comparisons (targets of issue 6):

1. ``PID`` block call from Python vs ``simple_pid.PID`` call (<= 0.5x);
2. ``ADRC`` block call vs ``pyadrc.StateSpace`` step (<= 0.1x); the same two calls
   with the compiled blocks (``ctrlblocks compile``): ``benchmarks/compiled_blocks.py``;
3. compiled closed loop (``ctrlblocks.fast.closed_loop``) vs C -O2, PID and
   ADRC n = 2 on a 3rd-order plant (<= 1.5x);
4. bank of N loops (``PIDBank``) per loop-step vs the C single-loop floor
   (<= 0.7x, state <= 200 bytes per loop);
5. the Nowak et al. 2018, Fig. 7 scenario (ADRC n = 2, PID_PT, PID_FT on the
   three-tank process, tracking and disturbance cases) compiled vs the same
   loops as python-control ``nlsys`` systems with saturation (>= 10,000x);
6. a sweep of the Fig. 7 scenario on a process pool vs one process
   (near-linear scaling to the cores).
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

Row = dict[str, object]


# ---------------------------------------------------------------------------
# timing helpers
# ---------------------------------------------------------------------------


def interleaved(fns: dict[str, Callable[[], float]], repeats: int) -> dict[str, list[float]]:
    """Call every ``fn`` (returns ns per unit) in turn, ``repeats`` times; the lists of results."""
    out: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            out[k].append(fn())
    return out


def per_call(fn: Callable[[], object], number: int) -> Callable[[], float]:
    """A timer: ns per call of ``fn`` over ``number`` calls."""

    def run() -> float:
        t0 = time.perf_counter_ns()
        for _ in range(number):
            fn()
        return (time.perf_counter_ns() - t0) / number

    return run


def row(name: str, ours: list[float], peer: list[float], target: str, ok: Callable[[float], bool],
        peer_name: str, unit: str = "ns") -> Row:  # fmt: skip
    r_min = min(ours) / min(peer)
    r_med = statistics.median(ours) / statistics.median(peer)
    return {
        "comparison": name,
        "ctrlblocks": f"{min(ours):.4g} / {statistics.median(ours):.4g} {unit}",
        "peer": f"{peer_name}: {min(peer):.4g} / {statistics.median(peer):.4g} {unit}",
        "ratio min/min": r_min,
        "ratio med/med": r_med,
        "target": target,
        "met": "yes" if ok(r_min) and ok(r_med) else ("min only" if ok(r_min) else "no"),
    }


# ---------------------------------------------------------------------------
# 1, 2: one call from Python
# ---------------------------------------------------------------------------


def bench_pid_call(repeats: int) -> Row:
    from simple_pid import PID as SimplePID

    from ctrlblocks import PID

    pid = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
    # simple-pid with the same features: P, I, D on measurement, output limits
    peer = SimplePID(2.0, 0.2, 1.0, setpoint=1.0, sample_time=None, output_limits=(0.0, 100.0))
    for _ in range(3):
        pid(1.0, 0.5)
        peer(0.5, dt=0.1)
    res = interleaved(
        {"ours": per_call(lambda: pid(1.0, 0.5), 20000),
         "peer": per_call(lambda: peer(0.5, dt=0.1), 20000),
         "bare": per_call(lambda: _bare_pid(1.0, 0.5, 0.1, 0.0, 0.5, 0.5, 2.0, 1.0, 1.0, 0.0,
                                            0.833, 0.833, 0.02, 0.5, 0.5, 0.0, 100.0), 20000)},
        repeats,
    )  # fmt: skip
    r = row("PID block call", res["ours"], res["peer"], "<= 0.5x", lambda r: r <= 0.5,
            "simple-pid call")  # fmt: skip
    bare = min(res["bare"]) / min(res["peer"])
    r["note"] = (
        f"floor in CPython: the bare PID arithmetic as one flat function (no block, no "
        f"state) takes {min(res['bare']):.0f} ns = {bare:.2f}x simple-pid"
    )
    return r


def _bare_pid(sp, pv, i, d, wp, ep, k, sgn, b, c, ad, bd, ki_h, alpha, beta, lo, hi):
    """The PID law of ``pid_step`` written flat (no calls): the CPython floor of a call."""
    e = sgn * (sp - pv)
    p = k * sgn * (b * sp - pv)
    w = sgn * (c * sp - pv)
    dn = ad * d + bd * (w - wp)
    di = ki_h * (alpha * ep + beta * e)
    ik = i + di
    v = p + ik + dn
    if (v > hi and di > 0.0) or (v < lo and di < 0.0):
        ik = i
    v = p + ik + dn
    out = lo if v < lo else hi if v > hi else v
    return out, v, p, ik, ik, dn, w, e


def bench_adrc_call(repeats: int) -> Row:
    from pyadrc import StateSpace

    from ctrlblocks import ADRC

    adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)
    peer = StateSpace(2, 0.1, 0.05, 0.35, 5.0, m_lim=(0.0, 5.0))
    for _ in range(3):
        adrc(1.0, 0.5)
        peer(0.5, 1.0, 1.0)
    from ctrlblocks.blocks.adrc import eso_euler

    coef = tuple(adrc.kernel_params())[:11]  # (h, b0, l1..l4, p1, p2, k1, k2, k3) of the ESO
    res = interleaved(
        {"ours": per_call(lambda: adrc(1.0, 0.5), 20000),
         "peer": per_call(lambda: peer(0.5, 1.0, 1.0), 5000),
         "eso": per_call(lambda: eso_euler(0.5, 0.0, 0.0, 0.0, 1.0, 0.5, 1.0, *coef), 20000)},
        repeats,
    )  # fmt: skip
    r = row("ADRC block call", res["ours"], res["peer"], "<= 0.1x", lambda r: r <= 0.1,
            "pyadrc StateSpace step")  # fmt: skip
    r["note"] = (
        f"floor in CPython: the ESO recursion (4a) alone takes {min(res['eso']):.0f} ns = "
        f"{min(res['eso']) / min(res['peer']):.2f}x pyadrc"
    )
    return r


# ---------------------------------------------------------------------------
# 3: compiled closed loop vs C
# ---------------------------------------------------------------------------


def build_c(tmp: Path) -> dict[str, Path]:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise SystemExit("no C compiler (cc) found: the C references need one")
    exe = {}
    for name in ("pid_loop", "adrc_loop"):
        for record in (1, 0):
            out = tmp / f"{name}_{record}"
            src = str(HERE / "c" / f"{name}.c")
            subprocess.run([cc, "-O2", f"-DRECORD={record}", "-o", str(out), src], check=True)
            exe[name if record else f"{name}_bare"] = out
    return exe


def _loop_setup():
    from ctrlblocks import ADRC, PID
    from ctrlblocks.fast.kernels import adrc_params, lti3_params, pid_params
    from ctrlblocks.plants import PTn

    def plant():
        return PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1)  # Nowak et al. 2018, (10b)

    def pid():
        return PID(kp=5.69, ti=16.65, td=2.91, ts=0.1, u_min=0.0, u_max=5.0)

    def adrc():
        return ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)

    pp = lti3_params(plant())
    plant_args = [repr(v) for v in (*pp[:12], *pp[15:18])]
    prm = pid_params(pid())
    pid_args = [repr(v) for v in prm[:11]]
    ap = adrc_params(adrc())
    adrc_args = [repr(v) for v in (*ap[:14], ap[17], ap[18], ap[19], ap[21])]
    return plant, pid, adrc, pid_args + plant_args, adrc_args + plant_args


def c_timer(
    exe: Path, n: int, args: list[str], sp: float = 1.0
) -> tuple[Callable[[], float], list[float]]:
    last: list[float] = []

    def run() -> float:
        r = subprocess.run([str(exe), str(n), "1", *args, repr(sp)], capture_output=True,
                           text=True, check=True)  # fmt: skip
        f = r.stdout.split()
        last[:] = [float(f[2]), float(f[3])]
        return float(f[0])

    return run, last


def bench_loops(exe: dict[str, Path], repeats: int, n: int) -> tuple[list[Row], float]:
    from ctrlblocks.fast import closed_loop

    plant, pid, adrc, pid_args, adrc_args = _loop_setup()
    rows = []
    floor = []
    for name, make, cexe, cargs in (("PID", pid, exe["pid_loop"], pid_args),
                                    ("ADRC n=2", adrc, exe["adrc_loop"], adrc_args)):  # fmt: skip
        ctrl, pl = make(), plant()
        closed_loop(ctrl, pl, sp=1.0, n=10)  # compile
        result = {}

        def ours(ctrl=ctrl, pl=pl, result=result) -> float:
            t0 = time.perf_counter_ns()
            r = closed_loop(ctrl, pl, sp=1.0, n=n)
            dt = (time.perf_counter_ns() - t0) / n
            result["y"], result["u"] = r.y[-1], r.u[-1]
            return dt

        c_run, c_last = c_timer(cexe, n, cargs)
        c_bare, _ = c_timer(exe[cexe.name.rsplit("_", 1)[0] + "_bare"], n, cargs)
        res = interleaved({"ours": ours, "c": c_run, "bare": c_bare}, repeats)
        same = abs(result["y"] - c_last[0]) <= 1e-12 and abs(result["u"] - c_last[1]) <= 1e-12
        r = row(f"compiled closed loop, {name} + 3rd-order plant", res["ours"], res["c"],
                "<= 1.5x", lambda x: x <= 1.5, "C -O2 (records y, u)")  # fmt: skip
        bare = row("", res["ours"], res["bare"], "", lambda x: True, "")
        r["note"] = (
            ("final y, u equal to C's" if same else "final y/u differ from C!")
            + f"; C without traces {min(res['bare']):.3g} ns: ratio {bare['ratio min/min']:.2f}"
            f" (min) / {bare['ratio med/med']:.2f} (median)"
        )
        rows.append(r)
        if name == "PID":
            floor = res["bare"]
    return rows, floor


# ---------------------------------------------------------------------------
# 4: bank of N loops
# ---------------------------------------------------------------------------


def bench_bank(exe: dict[str, Path], repeats: int, sizes: list[int], work: int) -> list[Row]:
    from ctrlblocks.fast import PIDBank

    _plant, _pid, _adrc, pid_args, _ = _loop_setup()
    c_run, _ = c_timer(exe["pid_loop_bare"], 1_000_000, pid_args)  # the floor: no traces
    rows = []
    rng = np.random.default_rng(1)
    for n_loops in sizes:
        bank = PIDBank.from_arrays(
            kp=rng.uniform(2.0, 6.0, n_loops), ti=rng.uniform(5.0, 17.0, n_loops),
            td=rng.uniform(0.5, 3.0, n_loops), n=5.0, ts=0.1, u_min=0.0, u_max=5.0,
            plant_k=rng.uniform(0.5, 1.0, n_loops),
            plant_t=np.sort(rng.uniform(1.0, 8.0, (n_loops, 3)), axis=1)[:, ::-1],
        )  # fmt: skip
        steps = max(20, work // n_loops)
        bank.run(1.0, 2)  # compile

        def ours(bank=bank, steps=steps, n_loops=n_loops) -> float:
            t0 = time.perf_counter_ns()
            bank.run(1.0, steps)
            return (time.perf_counter_ns() - t0) / (steps * n_loops)

        def ours_par(bank=bank, steps=steps, n_loops=n_loops) -> float:
            t0 = time.perf_counter_ns()
            bank.run(1.0, steps, parallel=True)
            return (time.perf_counter_ns() - t0) / (steps * n_loops)

        bank.run(1.0, 1, parallel=True)  # compile
        res = interleaved({"ours": ours, "c": c_run, "par": ours_par}, repeats)
        par = min(res["par"]) / min(res["c"])
        r = row(f"bank of {n_loops:,} PID loops, per loop-step", res["ours"], res["c"],
                "<= 0.7x", lambda x: x <= 0.7,
                "C -O2 one loop at a time (latency-bound), no traces")  # fmt: skip
        r["note"] = (f"one core; state {bank.state_bytes} B/loop (+"
                     f"{bank.stored_bytes - bank.state_bytes} B of its {bank.param_bytes} B of "
                     f"parameters not shared by all loops); {steps} steps; on all cores "
                     f"(parallel=True): "
                     f"{min(res['par']):.3g} ns = {par:.2f}x")  # fmt: skip
        rows.append(r)
    return rows


# ---------------------------------------------------------------------------
# 5: Nowak et al. 2018, Fig. 7 scenario vs python-control nlsys
# ---------------------------------------------------------------------------


def _fig7_runs():
    """The runs of scenarios/nowak_fig7.toml: 3 controllers x 2 cases (signals per sample)."""
    from ctrlblocks import ADRC, PID
    from ctrlblocks.plants import ThreeTank

    ts = 0.1
    tank = ThreeTank(ts=ts)
    u0 = tank.u_for_y(1.5)
    ctrls = {
        "ADRC n=2": lambda: ADRC(order=2, b0=0.05, omega_o=1.75, omega_c=0.35, ts=ts,
                                 u_min=0.0, u_max=5.0, u0=u0),
        "PID_PT": lambda: PID(kp=5.69, ti=16.65, td=2.91, n=5.0, ts=ts, u_min=0.0, u_max=5.0,
                              reset_value=u0),
        "PID_FT": lambda: PID(kp=6.31, ti=5.40, td=1.36, n=5.0, ts=ts, u_min=0.0, u_max=5.0,
                              reset_value=u0),
    }  # fmt: skip
    cases = {}
    n = round(140.0 / ts)
    sp = np.full(n, 1.5)
    sp[100:700] = 2.0
    cases["tracking"] = {"sp": sp, "load": np.zeros(n), "outlet": ["a"] * n}
    n = round(260.0 / ts)
    load = np.zeros(n)
    load[100:700] = 0.5
    outlet = ["a"] * 1300 + ["b"] * 650 + ["a"] * (n - 1950)
    cases["disturbance"] = {"sp": np.full(n, 1.5), "load": load, "outlet": outlet}
    rng = np.random.default_rng(7)
    for c in cases.values():
        c["noise"] = rng.normal(0.0, 0.001, len(c["sp"]))

    def plant():
        p = ThreeTank(ts=ts)
        p.reset(u0)
        return p

    return ctrls, cases, plant


def _nlsys_loop(make_ctrl, plant_factory, sig):
    """The same closed loop as a discrete-time python-control ``nlsys`` with saturation.

    State: the controller's and the plant's states; inputs: sp, load, noise,
    outlet coefficient.  The update function is what a python-control user
    writes: numpy state vector in, numpy state vector out, ``np.clip`` for the
    MV limits; the control law inside calls ctrlblocks' kernels.
    """
    import control

    from ctrlblocks import PID
    from ctrlblocks.fast.kernels import adrc_params, adrc_step, pid_params, pid_step
    from ctrlblocks.plants import threetank as tt

    ctrl = make_ctrl()
    plant = plant_factory()
    is_pid = isinstance(ctrl, PID)
    prm = pid_params(ctrl) if is_pid else adrc_params(ctrl)
    model = plant.discrete_model()
    g5 = model.g[:5]
    hsub, nsub = model.h, model.substeps
    g3o = model.outlet_g
    s = ctrl.kernel_state()
    if is_pid:
        x0c = [s.i, s.d, s.w_prev, s.e_prev, s.out, 1.0]
    else:
        x0c = [s.yh, s.x2, s.x3, s.x4, s.u_prev, s.ref, 0.0, 0.0, 0.0]
    nc = len(x0c)
    x0 = np.array([*x0c, *plant.snapshot()["p"], plant.u])

    def control_output(x, u_in):
        y = x[nc + 2] - tt.P_ATM + u_in[2]
        if is_pid:
            i, d, w, e, out, cold = x[:6]
            r = pid_step(u_in[0], y, 0.0, False, 0.0, cold != 0.0, False, i, d, w, e, out, prm)
            return r[0], (r[4], r[5], r[6], r[7], r[0], 0.0)
        yh, e2, e3, e4, up, ref, started, track, sat = x[:9]
        r = adrc_step(u_in[0], y, False, 0.0, started != 0.0, track != 0.0, int(sat),
                      yh, e2, e3, e4, up, ref, prm)  # fmt: skip
        return r[0], (r[2], r[3], r[4], r[5], r[0], r[6], 1.0, float(r[7]), float(r[8]))

    def updfcn(t, x, u_in, params):
        u, xc = control_output(x, u_in)
        ps = np.clip(u + u_in[1], plant.u_min, plant.u_max)  # actuator saturation
        p = tt.threetank_rk4(x[nc], x[nc + 1], x[nc + 2], ps + tt.P_ATM, (*g5, u_in[3]),
                             hsub, nsub)  # fmt: skip
        return np.array([*xc, *p, ps])

    def outfcn(t, x, u_in, params):
        u, _ = control_output(x, u_in)
        return np.array([x[nc + 2] - tt.P_ATM + u_in[2], u])

    sys_ = control.nlsys(updfcn, outfcn, inputs=4, outputs=2, states=len(x0), dt=0.1)
    n = len(sig["sp"])
    u_in = np.vstack([sig["sp"], sig["load"], sig["noise"], [g3o[v] for v in sig["outlet"]]])
    resp = control.input_output_response(sys_, np.arange(n) * 0.1, u_in, x0)
    return resp.outputs[0], resp.outputs[1]


def bench_fig7(repeats: int) -> Row:
    from ctrlblocks.fast import closed_loop

    ctrls, cases, plant = _fig7_runs()

    def ours() -> float:
        t0 = time.perf_counter_ns()
        for make in ctrls.values():
            for sig in cases.values():
                closed_loop(make(), plant(), **sig)
        return (time.perf_counter_ns() - t0) / 1e6  # ms

    def nlsys() -> float:
        t0 = time.perf_counter_ns()
        for make in ctrls.values():
            for sig in cases.values():
                _nlsys_loop(make, plant, sig)
        return (time.perf_counter_ns() - t0) / 1e6

    ours()  # compile
    # same numbers on both sides (one run each)
    worst = 0.0
    for make in ctrls.values():
        for sig in cases.values():
            a = closed_loop(make(), plant(), **sig)
            y, u = _nlsys_loop(make, plant, sig)
            worst = max(worst, float(np.max(np.abs(a.y - y))), float(np.max(np.abs(a.u - u))))
    res = interleaved({"ours": ours, "nlsys": nlsys}, repeats)
    samples = sum(len(sig["sp"]) for sig in cases.values()) * len(ctrls)
    runs = len(ctrls) * len(cases)
    name = f"Nowak et al. 2018, Fig. 7 scenario ({runs} runs, {samples:,} samples)"
    r = row(name, res["ours"], res["nlsys"], ">= 10,000x faster", lambda x: x <= 1e-4,
            "python-control nlsys", unit="ms")  # fmt: skip
    r["note"] = (
        f"speed-up {1 / r['ratio min/min']:,.0f}x (min) / {1 / r['ratio med/med']:,.0f}x "
        f"(median); max |difference| {worst:.1e}"
    )
    return r


# ---------------------------------------------------------------------------
# 6: sweeps scale to the cores
# ---------------------------------------------------------------------------


def _warm() -> None:
    import ctrlblocks.sim.runner  # noqa: F401  (imports done before the clock starts)


def bench_sweep(repeats: int) -> Row:
    import concurrent.futures as cf

    from ctrlblocks.sim import sweep

    vary = {"controllers[2].kp": [4.0, 5.0, 6.31, 7.0], "controllers[1].ti": [12.0, 16.65]}
    cores = os.cpu_count() or 1

    def serial() -> float:
        t0 = time.perf_counter()
        sweep("nowak_fig7", vary, executor="serial")
        return time.perf_counter() - t0

    def pooled() -> float:
        with cf.ProcessPoolExecutor(max_workers=cores, initializer=_warm) as ex:
            for f in [ex.submit(int) for _ in range(cores)]:
                f.result()  # workers up before the clock starts
            t0 = time.perf_counter()
            sweep("nowak_fig7", vary, executor=ex)
            return time.perf_counter() - t0

    def probe(pool: bool) -> Callable[[], float]:
        """The same split of pure-Python work: what the machine gives right now."""

        def run() -> float:
            if not pool:
                t0 = time.perf_counter()
                for _ in range(8):
                    _burn(1_500_000)
                return time.perf_counter() - t0
            with cf.ProcessPoolExecutor(max_workers=cores) as ex:
                for f in [ex.submit(int) for _ in range(cores)]:
                    f.result()
                t0 = time.perf_counter()
                list(ex.map(_burn, [1_500_000] * 8))
                return time.perf_counter() - t0

        return run

    res = interleaved({"pool": pooled, "serial": serial, "probe_pool": probe(True),
                       "probe_serial": probe(False)}, repeats)  # fmt: skip
    name = f"sweep, 8 sets of nowak_fig7, {cores} processes vs 1"
    r = row(name, res["pool"], res["serial"], f"~1/{cores} (near-linear)",
            lambda x: x <= 1.2 / cores, "serial", unit="s")  # fmt: skip
    ideal = min(res["probe_serial"]) / min(res["probe_pool"])
    r["note"] = (
        f"speed-up {1 / r['ratio min/min']:.2f}x on {cores} cores; the same split of pure "
        f"CPU work got {ideal:.2f}x in this run (the cores are shared with other jobs)"
    )
    return r


def _burn(n: int) -> int:
    s = 0
    for i in range(n):
        s += i * i
    return s


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numba

    cc = shutil.which("cc") or "cc"
    ccv = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()
    return (
        f"{cpu}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}; "
        f"Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}; "
        f"{ccv[0] if ccv else cc} -O2"
    )


def markdown(rows: list[Row]) -> str:
    cols = ["comparison", "ctrlblocks", "peer", "ratio min/min", "ratio med/med", "target", "met"]
    lines = ["| " + " | ".join(cols) + " | note |", "|" + "---|" * (len(cols) + 1)]
    for r in rows:
        cells = [f"{r[c]:.3g}" if isinstance(r[c], float) else str(r[c]) for c in cols]
        lines.append("| " + " | ".join(cells) + f" | {r.get('note', '')} |")
    return "\n".join(lines)


README_BEGIN = "<!-- benchmarks/run.py --readme: begin -->"
README_END = "<!-- benchmarks/run.py --readme: end -->"
README_ROWS = (
    ("compiled closed loop, PID + 3rd-order plant", "per sample"),
    ("compiled closed loop, ADRC n=2 + 3rd-order plant", "per sample"),
    ("bank of 1,000,000 PID loops, per loop-step", "per loop-step, one core"),
)
"""The README's table: (benchmark row, what one time is), in this order."""


def readme_table(rows: list[Row], conditions: str) -> str:
    """The README's performance table (between its markers) from benchmark rows.

    One row per :data:`README_ROWS`: the medians of ctrlblocks and of the C
    reference over the interleaved rounds and the ratio of the medians (the
    ratio holds better than the times on a shared machine), then the
    conditions of the run.
    """
    by_name = {str(r["comparison"]): r for r in rows}
    lines = [
        README_BEGIN,
        "| compiled by numba | time | C -O2, the same loop | ratio |",
        "|---|---|---|---|",
    ]
    for name, unit in README_ROWS:
        r = by_name[name]
        ours = str(r["ctrlblocks"]).split(" / ")[1]  # "min / median unit": the median
        peer_name, peer = str(r["peer"]).rsplit(": ", 1)
        peer_median = peer.split(" / ")[1]
        what = name.replace("compiled closed loop, ", "closed loop, ").replace(
            ", per loop-step", ""
        )
        lines.append(
            f"| {what} ({unit}) | {ours} | {peer_median} ({peer_name}) | "
            f"{float(r['ratio med/med']):.2f}x |"
        )
    lines += ["", conditions, README_END]
    return "\n".join(lines)


def update_readme(path: Path, table: str) -> None:
    """Replace the table between the markers of ``path`` with ``table``."""
    text = path.read_text(encoding="utf-8")
    i, j = text.index(README_BEGIN), text.index(README_END) + len(README_END)
    path.write_text(text[:i] + table + text[j:], encoding="utf-8")


def _conditions(load_before: float, load_after: float, repeats: int) -> str:
    return (
        f"Medians of {repeats} interleaved rounds, measured "
        f"{time.strftime('%Y-%m-%d')} on {machine()}; 1-minute load average "
        f"{load_before:.1f} before and {load_after:.1f} after the run "
        f"(`python benchmarks/run.py --readme`)."
    )


def _load() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover - not on every platform
        return float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats and samples")
    ap.add_argument("--markdown", type=Path, help="also write the table to this file")
    ap.add_argument(
        "--readme",
        action="store_true",
        help="run only the README's comparisons and print its table",
    )
    ap.add_argument(
        "--update",
        type=Path,
        metavar="README",
        help="with --readme: write the table into this file, between its markers",
    )
    args = ap.parse_args(argv)
    if args.update and not args.readme:
        ap.error("--update goes with --readme")
    if args.readme:
        return _readme(args)
    reps = 7 if args.quick else 15
    n_loop = 200_000 if args.quick else 1_000_000
    sizes = [10_000, 100_000] if args.quick else [10_000, 100_000, 1_000_000]
    rows: list[Row] = []
    print(f"machine: {machine()}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_c(Path(tmp))
        for label, fn in (
            ("PID call", lambda: [bench_pid_call(reps)]),
            ("ADRC call", lambda: [bench_adrc_call(reps)]),
            ("compiled loops", lambda: bench_loops(exe, reps, n_loop)[0]),
            ("bank", lambda: bench_bank(exe, max(3, reps // 3), sizes, 4_000_000)),
            ("Fig. 7 vs nlsys", lambda: [bench_fig7(3 if args.quick else 5)]),
            ("sweep", lambda: [bench_sweep(1 if args.quick else 3)]),
        ):
            t0 = time.perf_counter()
            new = fn()
            rows.extend(new)
            print(f"  {label}: done in {time.perf_counter() - t0:.0f} s", file=sys.stderr,
                  flush=True)  # fmt: skip
    table = markdown(rows)
    print(table)
    if args.markdown:
        args.markdown.write_text(f"Machine: {machine()}\n\n{table}\n", encoding="utf-8")
    return 0


def _readme(args: argparse.Namespace) -> int:
    """``--readme``: the compiled loops and the million-loop bank, then the README's table."""
    reps = 7 if args.quick else 15
    load0 = _load()
    print(f"machine: {machine()}; load average {load0:.1f}", file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_c(Path(tmp))
        t0 = time.perf_counter()
        rows = bench_loops(exe, reps, 200_000 if args.quick else 1_000_000)[0]
        print(f"  compiled loops: done in {time.perf_counter() - t0:.0f} s", file=sys.stderr,
              flush=True)  # fmt: skip
        t0 = time.perf_counter()
        rows += bench_bank(exe, max(3, reps // 3), [1_000_000], 4_000_000)
        print(f"  bank: done in {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    table = readme_table(rows, _conditions(load0, _load(), reps))
    print(table)
    if args.update:
        update_readme(args.update, table)
        print(f"wrote the table into {args.update}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
