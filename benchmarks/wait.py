"""Speed where users wait (issue 18): start-up, the kernel cache, reproduce, bank building, sweeps.

Usage (from the repository root, with ``pip install -e '.[bench]'`` and the
``dask`` extra for the Dask rows)::

    python benchmarks/wait.py                      # everything, ~10 minutes
    python benchmarks/wait.py --only startup,bank  # some sections
    python benchmarks/wait.py --quick              # fewer rounds

Every comparison runs its sides interleaved (A, B, A, B, ...) in fresh
processes where start-up matters, and reports medians and the ratio of the
medians of one run.  The machine is shared, so each section prints the load
average it saw and, for the parallel sections, what the same split of pure
CPU work gained on the cores at that moment.

Sections (targets of issue 18):

* ``startup``: ``ctrlblocks --help`` vs ``python -c "import numpy"`` (<= 2x);
  the ``--help`` of every sub-command and ``import ctrlblocks.plants``;
* ``cache``: first compiled call of ``closed_loop`` and of a bank in a fresh
  process, cold (empty cache folder) and warm (<= 1 s);
* ``reproduce``: all shipped scenarios on all cores vs the slowest single
  scenario (<= 3x), and vs all of them on one process;
* ``bank``: ``PIDBank.from_arrays`` of 10^6 loops vs 100 steps of it (<= 2x),
  resident and peak memory per loop;
* ``sweep``: 2 workers vs 1, process pool and Dask, batched vs one set per
  task (>= 1.7x when the second core is free);
* ``simulator``: the Nowak et al. 2018, Fig. 7 scenario through
  ``run_scenario`` (which dispatches its runs to the compiled lane) vs
  ``fast.closed_loop`` of the same six runs (<= 2x), and the forced Python path;
* ``structures``: cascades (PID and ADRC primaries), overrides (two and three
  blocks), a feed-forward and a Smith-predictor scenario through
  ``run_scenario`` on the compiled lane vs the Python path.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import _burn, _warm  # the pure-CPU probe and the worker warm-up of run.py

ROOT = Path(__file__).resolve().parent.parent
PY = sys.executable
Row = dict[str, str]


def load() -> str:
    """The 1-minute load average and the number of cores, as text."""
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def wall(cmd: list[str], env: dict[str, str] | None = None, cwd: Path | None = None) -> float:
    """Wall time of a subprocess [s] (output discarded; a failure raises)."""
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=env, cwd=cwd, timeout=1800)  # fmt: skip
    return time.perf_counter() - t0


def interleaved(fns: dict[str, Callable[[], float]], rounds: int) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(rounds):
        for k, fn in fns.items():
            out[k].append(fn())
    return out


def med(x: list[float]) -> float:
    return statistics.median(x)


def row(what: str, value: str, target: str, met: bool | None, note: str = "") -> Row:
    ok = "–" if met is None else ("yes" if met else "no")
    return {"measurement": what, "value": value, "target": target, "met": ok, "note": note}


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    env.update(extra)
    return env


# ---------------------------------------------------------------------------
# start-up
# ---------------------------------------------------------------------------

CLI = "from ctrlblocks.cli import main; main({args!r})"


def bench_startup(rounds: int) -> list[Row]:
    env = _env()
    cmds = {
        "numpy": [PY, "-c", "import numpy"],
        "help": [PY, "-c", CLI.format(args=["--help"])],
        "plants": [PY, "-c", "import ctrlblocks.plants"],
    }
    res = interleaved({k: (lambda c=c: wall(c, env)) for k, c in cmds.items()}, rounds)
    ratio = med(res["help"]) / med(res["numpy"])
    rows = [
        row("`ctrlblocks --help` / `python -c 'import numpy'`", f"{ratio:.2f}x "
            f"({med(res['help']):.2f} s / {med(res['numpy']):.2f} s)", "<= 2x", ratio <= 2.0,
            f"medians of {rounds} interleaved rounds; {load()}"),
        row("`import ctrlblocks.plants`", f"{med(res['plants']):.2f} s", "no scipy.signal",
            None, "scipy is imported at the first plant (scipy.linalg only)"),
    ]
    from ctrlblocks.cli import _COMMANDS

    sub = {n: [PY, "-c", CLI.format(args=[*n.split(), "--help"])]
           for n in [*sorted(_COMMANDS), "tune pid"]}  # fmt: skip
    sub["numpy"] = cmds["numpy"]
    res = interleaved({k: (lambda c=c: wall(c, env)) for k, c in sub.items()}, max(1, rounds // 2))
    numpy = med(res.pop("numpy"))
    text = ", ".join(f"{n} {med(v):.2f} ({med(v) / numpy:.1f}x)" for n, v in res.items())
    worst = max(med(v) for v in res.values()) / numpy
    rows.append(row("`ctrlblocks CMD --help` [s] (/ `import numpy`)", text,
                    "imports only what CMD uses", worst <= 2.0,
                    f"worst {worst:.2f}x `import numpy` ({numpy:.2f} s); no --help imports "
                    "scipy, matplotlib, numba, asyncua, ... (tests/test_cli.py); "
                    f"medians of {max(1, rounds // 2)} interleaved rounds; {load()}"))  # fmt: skip
    return rows


# ---------------------------------------------------------------------------
# the disk cache of the compiled kernels
# ---------------------------------------------------------------------------

FIRST_CALL = """
import json, time
t0 = time.perf_counter()
import numpy as np
from ctrlblocks import PID
from ctrlblocks.plants import PTn
from ctrlblocks.fast import PIDBank, closed_loop
t1 = time.perf_counter()
pid = PID(kp=5.69, ti=16.65, td=2.91, ts=0.1, u_min=0.0, u_max=5.0)
plant = PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1)
t2 = time.perf_counter()
closed_loop(pid, plant, np.ones(1000))
t3 = time.perf_counter()
PIDBank.from_arrays(kp=[2.0, 3.0], ti=8.0, td=0.5, ts=0.1, plant_k=0.73,
                    plant_t=[[7.3, 2.2, 1.4]] * 2).run(1.0, 10)
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "loop": t3 - t2, "bank": t4 - t3}))
"""


def _first_call(cache: Path) -> dict[str, float]:
    out = subprocess.run([PY, "-c", FIRST_CALL], capture_output=True, text=True, check=True,
                         env=_env(CTRLBLOCKS_NUMBA_CACHE=str(cache)), timeout=1800)  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_cache(rounds: int) -> list[Row]:
    with tempfile.TemporaryDirectory() as tmp:
        cold = _first_call(Path(tmp))
        warm = [_first_call(Path(tmp)) for _ in range(rounds)]
    loop = med([w["loop"] for w in warm])
    bank = med([w["bank"] for w in warm])
    imp = med([w["import"] for w in warm])
    return [
        row("first compiled call in a fresh process, warm cache (closed_loop)", f"{loop:.2f} s",
            "<= 1 s", loop <= 1.0, f"cold (empty cache) {cold['loop']:.1f} s; median of "
            f"{rounds} processes; {load()}"),
        row("first bank (from_arrays + run) in a fresh process, warm cache", f"{bank:.2f} s",
            "<= 1 s", bank <= 1.0, f"cold {cold['bank']:.1f} s; importing ctrlblocks.fast, "
            f"numba and the blocks {imp:.2f} s before that"),
    ]


# ---------------------------------------------------------------------------
# reproduce on all cores
# ---------------------------------------------------------------------------


def bench_reproduce(rounds: int) -> list[Row]:
    from ctrlblocks.sim.report import shipped_scenarios

    names = [p.stem for p in shipped_scenarios()]
    cores = os.cpu_count() or 1
    env = _env()
    with tempfile.TemporaryDirectory() as tmp:

        def repro(*args: str) -> float:
            return wall([PY, "-c", CLI.format(args=["reproduce", "--out", tmp, *args])], env)

        single = {n: repro(n, "--jobs", "1") for n in names}
        slowest = max(single, key=single.__getitem__)
        sides = {
            "all": lambda: repro("--jobs", str(cores)),
            "slowest": lambda: repro(slowest, "--jobs", "1"),
            "all-serial": lambda: repro("--jobs", "1"),
            "all-no-plots": lambda: repro("--jobs", str(cores), "--no-plots"),
        }
        res = interleaved(sides, rounds)
    r_all = med(res["all"]) / med(res["slowest"])
    return [
        row(f"`reproduce` (all {len(names)} scenarios, --jobs {cores}) / slowest single "
            f"scenario (`reproduce {slowest}`)", f"{r_all:.2f}x ({med(res['all']):.1f} s / "
            f"{med(res['slowest']):.1f} s)", "<= 3x", r_all <= 3.0,
            f"medians of {rounds} interleaved rounds, whole commands; {load()}"),
        row(f"`reproduce` --jobs {cores} vs --jobs 1", f"{med(res['all-serial']):.1f} s -> "
            f"{med(res['all']):.1f} s ({med(res['all-serial']) / med(res['all']):.2f}x)",
            "all cores", None, f"--no-plots: {med(res['all-no-plots']):.1f} s"),
        row("single scenarios, once each [s]", ", ".join(f"{n} {t:.1f}" for n, t in
            sorted(single.items(), key=lambda kv: -kv[1])), "", None),
    ]


# ---------------------------------------------------------------------------
# bank building
# ---------------------------------------------------------------------------

BANK = """
import json, sys, time
import numpy as np
from ctrlblocks.fast import PIDBank

def status():
    d = {}
    for line in open("/proc/self/status"):
        k, _, v = line.partition(":")
        if k in ("VmRSS", "VmHWM"):
            d[k] = int(v.split()[0]) * 1024
    return d

n, rounds = int(sys.argv[1]), int(sys.argv[2])
rng = np.random.default_rng(1)
args = dict(kp=rng.uniform(2, 6, n), ti=rng.uniform(5, 17, n), td=rng.uniform(0.5, 3, n),
            plant_k=rng.uniform(0.5, 1.0, n), plant_t=rng.uniform(1.0, 8.0, (n, 3)))
small = {k: v[:8] for k, v in args.items()}
PIDBank.from_arrays(ts=0.1, u_min=0.0, u_max=5.0, **small).run(1.0, 2)  # compile or load
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # reset the peak (VmHWM) to the current RSS
base = status()["VmRSS"]
build, run = [], []
for r in range(rounds):
    t0 = time.perf_counter()
    bank = PIDBank.from_arrays(ts=0.1, u_min=0.0, u_max=5.0, **args)
    t1 = time.perf_counter()
    res = bank.run(1.0, 100)
    t2 = time.perf_counter()
    build.append(t1 - t0)
    run.append(t2 - t1)
    if r == 0:
        st = status()
        mem = {"resident": (st["VmRSS"] - base) / n, "peak": (st["VmHWM"] - base) / n,
               "stored": bank.stored_bytes}
        del res
        mem["bank"] = (status()["VmRSS"] - base) / n  # the bank alone, the result dropped
    else:
        del res
    del bank
print(json.dumps({"build": build, "run100": run, **mem}))
"""


def bench_bank(rounds: int, n: int = 1_000_000) -> list[Row]:
    out = subprocess.run([PY, "-c", BANK, str(n), str(rounds)], capture_output=True, text=True,
                         check=True, env=_env(), timeout=1800)  # fmt: skip
    r = json.loads(out.stdout.strip().splitlines()[-1])
    b, s = med(r["build"]), med(r["run100"])
    peak_ratio = r["peak"] / r["resident"]
    return [
        row(f"`PIDBank.from_arrays` of {n:,} loops / 100 steps of it", f"{b / s:.2f}x "
            f"({b:.2f} s / {s:.2f} s)", "<= 2x", b / s <= 2.0,
            f"medians of {rounds} rounds (build, run, build, run ...), one core; {load()}"),
        row("bank memory per loop (RSS, after build and a run)", f"bank {r['bank']:.0f} B; "
            f"with the run's result {r['resident']:.0f} B, peak {r['peak']:.0f} B "
            f"({peak_ratio:.2f}x)", "peak <= 1.5x resident; resident <= 200 B",
            peak_ratio <= 1.5 and r["bank"] <= 200,
            f"the bank stores {r['stored']} B/loop (80 B state + the parameters not shared by "
            "all loops); the result the caller holds (y, u, iae) adds 24 B"),
    ]


# ---------------------------------------------------------------------------
# sweeps on 2 workers
# ---------------------------------------------------------------------------


def _warm_sweep() -> None:
    """A worker's warm-up: one short run of the benchmark's scenario (imports, kernels loaded)."""
    from ctrlblocks.sim.sweep import read_scenario_text, run_batch

    text, file = read_scenario_text("nowak_fig7")
    run_batch(text, file, [{}], duration=5.0)


def bench_sweep(rounds: int) -> list[Row]:
    import concurrent.futures as cf

    from ctrlblocks.sim import sweep

    # a study of 480 sets of the whole Fig. 7 scenario (six runs of 200 s each per set): on
    # the compiled lane a set takes ~5-10 ms, so the study is a few seconds of work -- the
    # size at which a user reaches for a second core (96 sets of 2 s, the earlier choice
    # when a set took ~130 ms on the Python path, are now under a second in all)
    vary = {"controllers[2].kp": [4.0 + 0.05 * i for i in range(48)],
            "controllers[2].ti": [4.4, 4.9, 5.4, 5.9, 6.4], "sensor.noise": [0.0, 0.002]}
    n_sets = 480
    duration = None  # the scenario's own duration

    def pool_side(workers: int, batch: int | None, warm: bool = True) -> Callable[[], float]:
        # warm: each worker has run one short set of the scenario before the clock starts (its
        # imports done, the compiled kernels loaded from the disk cache: ~0.8 s per process,
        # goal 2's cost, paid once per worker); cold: imports only, as a fresh pool a user makes
        init = _warm_sweep if warm else _warm

        def run() -> float:
            with cf.ProcessPoolExecutor(max_workers=workers, initializer=init) as ex:
                for f in [ex.submit(int) for _ in range(workers)]:
                    f.result()  # workers up before the clock starts
                t0 = time.perf_counter()
                sweep("nowak_fig7", vary, executor=ex, duration=duration, batch=batch)
                return time.perf_counter() - t0

        return run

    def probe(workers: int) -> Callable[[], float]:
        def run() -> float:
            with cf.ProcessPoolExecutor(max_workers=workers) as ex:
                for f in [ex.submit(int) for _ in range(workers)]:
                    f.result()
                t0 = time.perf_counter()
                list(ex.map(_burn, [400_000] * 16))
                return time.perf_counter() - t0

        return run

    sides: dict[str, Callable[[], float]] = {
        "pool1": pool_side(1, None),
        "pool2": pool_side(2, None),
        "pool2-single": pool_side(2, 1),
        "pool1-cold": pool_side(1, None, warm=False),
        "pool2-cold": pool_side(2, None, warm=False),
        "probe1": probe(1),
        "probe2": probe(2),
    }
    dask_note = "distributed not installed"
    clients = {}
    try:
        from ctrlblocks.sim import dask_executor

        for w in (1, 2):
            clients[w] = dask_executor(n_workers=w, threads_per_worker=1, processes=True,
                                       dashboard_address="127.0.0.1:0")  # fmt: skip
        for w in (1, 2):
            clients[w]._client.run(_warm_sweep)  # on every worker of the cluster

        def dask_side(w: int, batch: int | None) -> Callable[[], float]:
            def run() -> float:
                t0 = time.perf_counter()
                sweep("nowak_fig7", vary, executor=clients[w], duration=duration, batch=batch)
                return time.perf_counter() - t0

            return run

        sides |= {"dask1": dask_side(1, None), "dask2": dask_side(2, None),
                  "dask2-single": dask_side(2, 1)}  # fmt: skip
    except ImportError:
        pass
    loads = [os.getloadavg()[0]]
    try:
        res = interleaved(sides, rounds)
    finally:
        for ex in clients.values():
            ex.shutdown()
    loads.append(os.getloadavg()[0])
    probe_gain = med(res["probe1"]) / med(res["probe2"])
    seen = (f"load {loads[0]:.1f} -> {loads[1]:.1f} on {os.cpu_count()} cores; pure CPU work "
            f"split the same way gained {probe_gain:.2f}x on 2 workers in this run")  # fmt: skip
    per_set = med(res["pool1"]) / n_sets
    rows = []
    for kind in ("pool", "dask"):
        if f"{kind}1" not in res:
            rows.append(row("Dask sweep", "–", ">= 1.7x", None, dask_note))
            continue
        gain = med(res[f"{kind}1"]) / med(res[f"{kind}2"])
        single = med(res[f"{kind}1"]) / med(res[f"{kind}2-single"])
        name = "process pool" if kind == "pool" else "Dask LocalCluster (processes)"
        value = f"{gain:.2f}x (batched); {single:.2f}x with one set per task"
        if kind == "pool":
            cold = med(res["pool1-cold"]) / med(res["pool2-cold"])
            value += f"; {cold:.2f}x batched on a fresh pool (workers not warmed)"
        note = f"medians of {rounds} interleaved rounds; {seen}"
        if gain < 1.7 and probe_gain < 1.7:  # the machine, not the sweep: say so
            note += (f"; the 2nd core is not free (pure CPU work gains < 1.7x): the sweep "
                     f"reached {gain / probe_gain:.0%} of what it gave")  # fmt: skip
        rows.append(row(f"sweep on {name}: 2 workers vs 1 ({n_sets} sets of ~{per_set * 1e3:.0f}"
                        " ms; workers warmed)", value, ">= 1.7x when the 2nd core is free",
                        gain >= 1.7, note))  # fmt: skip
    return rows


# ---------------------------------------------------------------------------


# ---------------------------------------------------------------------------
# the simulator on the compiled lane
# ---------------------------------------------------------------------------


def bench_simulator(rounds: int) -> list[Row]:
    from run import _fig7_runs

    from ctrlblocks.fast import closed_loop
    from ctrlblocks.sim import run_scenario
    from ctrlblocks.sim.dispatch import simulate
    from ctrlblocks.sim.report import load_shipped

    (sc,) = load_shipped(["nowak_fig7"])
    ctrls, cases, plant = _fig7_runs()

    def timed(fn: Callable[[], object]) -> Callable[[], float]:
        def run() -> float:
            t0 = time.perf_counter()
            fn()
            return time.perf_counter() - t0

        return run

    def loops() -> None:
        for make in ctrls.values():
            for sig in cases.values():
                closed_loop(make(), plant(), **sig)

    def runs_only() -> None:
        cache: dict = {}  # what run_scenario shares between the runs of a case
        for case in sc.cases:
            for ctrl in sc.controllers:
                simulate(sc, ctrl, case, cache=cache)

    sides = {
        "run_scenario": timed(lambda: run_scenario(sc)),
        "closed_loop": timed(loops),
        "simulate": timed(runs_only),
    }
    for fn in sides.values():
        fn()  # compile or load the kernels, import everything
    res = interleaved(sides, rounds)
    python = interleaved({"python": timed(lambda: run_scenario(sc, engine="python"))},
                         max(1, rounds // 5))["python"]  # fmt: skip
    ms = {k: 1e3 * med(v) for k, v in res.items()}
    r = ms["run_scenario"] / ms["closed_loop"]
    return [
        row("Fig. 7 scenario (6 runs, 12,000 samples): `run_scenario` / `fast.closed_loop` "
            "of the same runs", f"{r:.2f}x ({ms['run_scenario']:.2f} ms / "
            f"{ms['closed_loop']:.2f} ms)", "<= 2x", r <= 2.0,
            f"medians of {rounds} interleaved rounds, one process; {load()}"),
        row("... of which the six simulations (`sim.dispatch.simulate`, no metrics)",
            f"{ms['simulate']:.2f} ms ({ms['simulate'] / ms['closed_loop']:.2f}x closed_loop)",
            "", None, "the rest: metrics of every run and event window, claims"),
        row("Fig. 7 `run_scenario(engine=\"python\")` (the reference path)",
            f"{1e3 * med(python):.0f} ms ({1e3 * med(python) / ms['run_scenario']:.0f}x auto)",
            "", None, f"median of {len(python)}; {load()}"),
    ]


# the structures on the compiled lane: cascade and feed-forward as scenarios of their own
# (no shipped scenario has them), override and Smith as shipped (astrom_fig39, nowak_smith)

_STRUCTURE_HEAD = """
[scenario]
name = "{name}"
title = "{name}"
source = "benchmark"
structure = "{name}"
ts = 0.1
duration = 600.0
seed = 3
[sensor]
noise = 0.01
[initial]
y = 0.5
warmup = 2.0
[[events]]
t = 2.0
do = "setpoint"
value = 1.5
[[events]]
t = 200.0
do = "load"
value = -0.2
[[events]]
t = 400.0
do = "setpoint"
value = 1.0
"""

CASCADE_BENCH = _STRUCTURE_HEAD.format(name="cascade") + """
[inner_plant]
type = "PT1"
k = 1.0
t = 1.5
[plant]
type = "FOPDT"
k = 1.5
t = 8.0
dead_time = 1.0
[actuator]
u_min = 0.0
u_max = 1.2
[[controllers]]
name = "PID / PID"
[controllers.primary]
type = "PID"
kp = 1.5
ti = 8.0
u_min = -1.0
u_max = 3.0
[controllers.secondary]
type = "PID"
kp = 2.0
ti = 1.0
u_min = 0.0
u_max = 1.2
"""

FEEDFORWARD_BENCH = _STRUCTURE_HEAD.format(name="feedforward") + """
[plant]
type = "PTn"
k = 2.0
t = [3.0, 1.0]
dead_time = 0.5
[[controllers]]
name = "PID + lead-lag"
[controllers.main]
type = "PID"
kp = 0.8
ti = 4.0
td = 0.5
u_min = -2.0
u_max = 2.0
[controllers.feedforward]
type = "LeadLag"
k = -1.0
t_lead = 2.0
t_lag = 1.0
"""


# the cascade with an ADRC primary and the AW handshake (awin of the ADRC on the lane)
CASCADE_ADRC_BENCH = CASCADE_BENCH.replace('name = "PID / PID"', 'name = "ADRC / PID"').replace(
    'type = "PID"\nkp = 1.5\nti = 8.0\n',
    'type = "ADRC"\norder = 1\nb0 = 0.2\nomega_c = 0.3\nomega_o = 1.5\n',
)

# an override of three blocks (the lane's override kernel holds any number)
OVERRIDE3_BENCH = _STRUCTURE_HEAD.format(name="override") + """
[inner_plant]
type = "PT1"
k = 1.0
t = 1.0
[plant]
type = "PT2"
k = 2.0
t1 = 4.0
t2 = 1.0
[actuator]
u_min = -0.5
u_max = 1.0
[[controllers]]
name = "three PIDs, min selector"
selector = "min"
[[controllers.blocks]]
measure = "y"
type = "PID"
kp = 1.0
ti = 3.0
u_min = -0.5
u_max = 1.0
anti_windup = "back_calc_model"
[[controllers.blocks]]
measure = "y2"
sp = 0.45
type = "PID"
kp = 6.0
ti = 0.5
u_min = -0.5
u_max = 1.0
[[controllers.blocks]]
measure = "y"
sp = 1.3
type = "PID"
kp = 2.0
ti = 2.0
u_min = -0.5
u_max = 1.0
"""


def bench_structures(rounds: int) -> list[Row]:
    """Each structure's scenario through ``run_scenario``: the compiled lane vs the Python path."""
    from ctrlblocks.sim import parse_scenario, run_scenario
    from ctrlblocks.sim.report import load_shipped

    fig39, smith = load_shipped(["astrom_fig39", "nowak_smith"])
    scenarios = {
        "cascade (PID / PID, PT1 into FOPDT)": parse_scenario(CASCADE_BENCH),
        "override (astrom_fig39: two PIDs, min selector)": fig39,
        "feed-forward (PID + lead-lag, PT2 with dead time)": parse_scenario(FEEDFORWARD_BENCH),
        "Smith predictor (nowak_smith: two ADRCs)": smith,
        "cascade (ADRC / PID with the AW handshake)": parse_scenario(CASCADE_ADRC_BENCH),
        "override of three blocks (three PIDs, min selector)": parse_scenario(OVERRIDE3_BENCH),
    }

    def timed(sc: object, engine: str) -> Callable[[], float]:
        def run() -> float:
            t0 = time.perf_counter()
            run_scenario(sc, engine=engine)
            return time.perf_counter() - t0

        return run

    sides = {}
    for name, sc in scenarios.items():
        sides[f"{name}/auto"] = timed(sc, "auto")
        sides[f"{name}/python"] = timed(sc, "python")
        sides[f"{name}/auto"]()  # compile or load the lane, import everything
    n_py = max(1, rounds // 3)
    res = interleaved({k: v for k, v in sides.items() if k.endswith("/auto")}, rounds)
    res |= interleaved({k: v for k, v in sides.items() if k.endswith("/python")}, n_py)
    rows = []
    for name, sc in scenarios.items():
        samples = sum(round(c.duration / sc.ts) for c in sc.cases) * len(sc.controllers)
        auto, py = med(res[f"{name}/auto"]), med(res[f"{name}/python"])
        rows.append(row(
            f"{name}: `run_scenario`, compiled lane / Python path", f"{auto / py:.3f} "
            f"({1e3 * auto:.1f} ms / {1e3 * py:.0f} ms; {py / auto:.0f}x faster)", "", None,
            f"{samples:,} samples: {1e9 * auto / samples:.0f} ns / {1e9 * py / samples:.0f} ns "
            f"per sample incl. metrics; medians of {rounds} / {n_py} rounds; {load()}",
        ))  # fmt: skip
    return rows


SECTIONS = {
    "startup": bench_startup,
    "cache": bench_cache,
    "reproduce": bench_reproduce,
    "bank": bench_bank,
    "sweep": bench_sweep,
    "simulator": bench_simulator,
    "structures": bench_structures,
}


def markdown(rows: list[Row]) -> str:
    cols = ["measurement", "value", "target", "met", "note"]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(r[c] for c in cols) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds")
    ap.add_argument("--only", default=",".join(SECTIONS), help="comma-separated sections")
    ap.add_argument("--rounds", type=int, help="rounds of every section (default: per section)")
    ap.add_argument("--markdown", type=Path, help="also write the table to this file")
    args = ap.parse_args(argv)
    rounds = {"startup": 9, "cache": 5, "reproduce": 3, "bank": 3, "sweep": 5, "simulator": 15,
              "structures": 9}
    rows: list[Row] = []
    for name in args.only.split(","):
        n = rounds[name] if not args.quick else max(1, rounds[name] // 3)
        n = args.rounds or n
        t0 = time.perf_counter()
        rows.extend(SECTIONS[name](n))
        print(f"  {name}: done in {time.perf_counter() - t0:.0f} s ({load()})", file=sys.stderr,
              flush=True)  # fmt: skip
    table = markdown(rows)
    print(table)
    if args.markdown:
        args.markdown.write_text(table + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
