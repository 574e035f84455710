"""Loop structures in the runtime: cascade, override, feed-forward, Smith predictor.

The runtime runs the simulator's :class:`~ctrlblocks.loops.ControllerSide`, and
the plant is the simulator's :class:`~ctrlblocks.sim.ProcessSide` (through
:class:`~ctrlblocks.sim.PlantProcess`, stepped on each MV write), so the
runtime's recorded SP/PV/MV trace must equal ``simulate`` of the same
scenario bit for bit (in memory, and over OPC UA Double variables).
"""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from ctrlblocks.runtime import (
    FakeClock,
    MemoryAdapter,
    MemoryBus,
    PlantServer,
    Runtime,
    RuntimeConfigError,
    parse_config,
)
from ctrlblocks.sim import PlantProcess, parse_scenario, simulate

from .conftest import block_table, fresh, toml_value, wait_for

HEAD = """
[scenario]
name = "{name}"
title = "runtime structure test"
structure = "{structure}"
ts = {ts}
duration = {duration}
"""


def _pi(kp: float, ti: float, lo: float, hi: float, extra: str = "") -> str:
    return f'type = "PID"\nkp = {kp}\nti = {ti}\nu_min = {lo}\nu_max = {hi}\n{extra}'


def cascade(ts: float = 0.1, duration: float = 30.0) -> str:
    """Åström 1987, section 3 "Cascade Control": the secondary saturates, the AW handshake acts."""
    return (
        HEAD.format(name="cascade", structure="cascade", ts=ts, duration=duration)
        + """
[inner_plant]
type = "PT1"
k = 1.0
t = 1.0

[plant]
type = "PT1"
k = 1.0
t = 4.0

[[controllers]]
name = "cascade"
[controllers.primary]
"""
        + _pi(1.5, 4.0, -5.0, 5.0)
        + "[controllers.secondary]\n"
        + _pi(2.0, 1.0, 0.0, 1.2)
        + f"""
[[events]]
t = {5 * ts}
do = "setpoint"
value = 1.0

[[events]]
t = {0.5 * duration}
do = "load"
at = "inner"
value = -0.2
"""
    )


OVERRIDE = (
    HEAD.format(name="override", structure="override", ts=0.05, duration=20.0)
    + """
[inner_plant]          # x2 (Åström 1987, Fig. 3.8)
type = "PT1"
k = 1.0
t = 1.0

[plant]                # x1
type = "LinearPlant"
num = [1.0]
den = [1.0, 0.0]

[initial]
sp = 1.0
u = 0.0

[[controllers]]
name = "min selector"
selector = "min"

[[controllers.blocks]]   # R1 on x1
type = "PID"
measure = "y"
sp = "sp"
kp = 1.0
b = 0.5
ti = 2.5
tt = 0.5
u_min = -0.4
u_max = 0.4
anti_windup = "back_calc_model"
integral_method = "backward"

[[controllers.blocks]]   # R2 on x2, setpoint x2max = 0.2
type = "PID"
measure = "y2"
sp = 0.2
kp = 9.0
ti = 0.36
tt = 0.072
u_min = -0.4
u_max = 0.4
anti_windup = "back_calc_model"
integral_method = "backward"

[[events]]
t = 12.0
do = "load"
at = "inner"
value = -0.15
"""
)

FEEDFORWARD = (
    HEAD.format(name="feedforward", structure="feedforward", ts=0.1, duration=20.0)
    + """
[plant]
type = "PT2"
k = 2.0
t1 = 3.0
t2 = 1.0

[initial]
sp = 0.0

[[controllers]]
name = "lead-lag feed-forward"
[controllers.main]
"""
    + _pi(1.0, 4.0, -10.0, 10.0)
    + """
[controllers.feedforward]
type = "LeadLag"
k = -0.5
t_lead = 3.0
t_lag = 1.0

[[events]]
t = 3.0
do = "load"
value = 0.5

[[events]]
t = 10.0
do = "setpoint"
value = 0.5
"""
)

SMITH = (
    HEAD.format(name="smith", structure="smith", ts=0.1, duration=25.0)
    + """
[plant]
type = "FOPDT"
k = 1.0
t = 5.0
dead_time = 4.0

[initial]
u = 0.3

[[controllers]]
name = "smith"
[controllers.main]
"""
    + _pi(3.0, 5.0, -10.0, 10.0)
    + """
[controllers.model]
type = "FOPDT"
k = 1.0
t = 5.0
dead_time = 4.0

[[events]]
t = 1.0
do = "setpoint"
value = 1.0

[[events]]
t = 15.0
do = "load"
value = 0.2
"""
)


# -- helpers ---------------------------------------------------------------------------


def _table(spec, *, drop=("u_sf", "safe_value")) -> str:
    params = {k: v for k, v in spec.params.items() if k not in drop}
    params.update(spec.extra.items())
    params.pop("tuned", None)
    return block_table(spec.type, params)


def _inline(table: dict) -> str:
    return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in table.items()) + " }"


def loop_tables(sc, *, pv="pv", pv2="pv2", dv="dv", conn="io", sp='"io:sp"') -> str:
    """A runtime loop with the scenario's first controller entry (same tables)."""
    ctrl = sc.controllers[0]
    s = sc.structure
    lines = ['name = "loop"', f"ts = {sc.ts}", f'structure = "{s}"']
    b = ctrl.blocks
    if s == "cascade":
        lines += [
            f"primary = {_table(b['primary'], drop=())}",
            f"secondary = {_table(b['secondary'])}",
        ]
        lines += [f'pv = "{conn}:{pv}"', f'pv2 = "{conn}:{pv2}"']
        lines.append(f"aw_handshake = {toml_value(ctrl.options.get('aw_handshake', True))}")
    elif s == "override":
        lines.append(f'selector = "{ctrl.options["selector"]}"')
        lines.append("blocks = [" + ", ".join(_table(x) for x in b["blocks"]) + "]")
        lines += [f'pv = "{conn}:{pv}"', f'pv2 = "{conn}:{pv2}"']
    elif s == "feedforward":
        lines += [f"main = {_table(b['main'])}", f"feedforward = {_table(b['feedforward'])}"]
        lines += [f'pv = "{conn}:{pv}"', f'dv = "{conn}:{dv}"']
    elif s == "split_range":
        split = ctrl.options["split"]
        table = {"split": split.split, "gap": split.gap, "a": list(split.a), "b": list(split.b)}
        lines += [f"main = {_table(b['main'])}", f"split = {_inline(table)}"]
        lines += [f'pv = "{conn}:{pv}"', f'mv2 = "{conn}:mv2"', f"u0 = {PlantProcess(sc).u0!r}"]
    elif s == "ratio":
        cfg = ctrl.options["ratio"]
        table = {k: getattr(cfg, k) for k in ("r_min", "r_max", "bias", "rate")}
        lines += [f"main = {_table(b['main'])}", f"ratio = {_inline(table)}"]
        lines += [f'pv = "{conn}:{pv}"', f'wild = "{conn}:wild"']
    else:  # smith
        lines += [f"main = {_table(b['main'])}", f"model = {_table(b['model'])}"]
        lines += [f'pv = "{conn}:{pv}"', f"u0 = {PlantProcess(sc).u0!r}"]
    lines += [f'mv = "{conn}:mv"', f"sp = {sp}", "safe_value = 0.0"]
    # the blocks start from their own initial state, as the simulator's do (no read-back)
    lines.append('start = "block"')
    return "[[loops]]\n" + "\n".join(lines) + "\n"


def run_in_memory(sc, n: int, *, fault=None):
    """The runtime on a fake clock against the scenario's process on a memory bus."""
    process = PlantProcess(sc)
    bus = MemoryBus(process.values())

    written: dict[str, float] = {}
    mvs = {"mv", "mv2"} if sc.structure == "split_range" else {"mv"}

    def on_write(address: str, u: float) -> None:
        if address in mvs:  # the plant steps once all MVs of the cycle are written
            written[address] = u
            if set(written) == mvs:
                process.step(written.pop("mv"), written.pop("mv2", None))
                bus.values.update(process.values())

    bus.on_write = on_write
    text = '[connections.io]\nprotocol = "memory"\n' + loop_tables(sc)
    cfg = parse_config(text + '[historian]\nbackend = "none"\n')
    clock = FakeClock()
    rows: list[dict] = []
    rt = Runtime(cfg, clock=clock, adapters={"io": MemoryAdapter(bus)}, historian=None)
    lp = rt.loops["loop"]

    def on_sample(s):
        rows.append({**vars(s), **{f"m_{k}": v for k, v in lp.measurements.items()}})
        if fault is not None:
            fault(len(rows), bus)

    rt.on_sample = on_sample

    async def main():
        await rt.start()
        await clock.run_until((n - 0.5) * sc.ts)
        await rt.stop()

    asyncio.run(main())
    return rows[:n], rt


def arrays(rows, *names):
    return [np.array([r[k] for r in rows], dtype=float) for k in names]


# -- the runtime equals the simulator ------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "n"),
    [(cascade(), 300), (OVERRIDE, 400), (FEEDFORWARD, 200), (SMITH, 250)],
    ids=["cascade", "override", "feedforward", "smith"],
)
def test_runtime_trace_equals_the_simulator_bit_for_bit(text, n):
    sc = parse_scenario(text)
    rows, _ = run_in_memory(sc, n)
    assert len(rows) == n and not any(r["overrun"] for r in rows)
    ref = simulate(sc, sc.controllers[0].name).signals
    sp, pv, mv = arrays(rows, "sp", "pv", "mv")
    np.testing.assert_array_equal(mv, ref["u"][:n])
    np.testing.assert_array_equal(pv, ref["ym"][:n])
    np.testing.assert_array_equal(sp, ref["sp"][:n])
    if sc.structure in ("cascade", "override"):
        (pv2,) = arrays(rows, "m_pv2")
        np.testing.assert_array_equal(pv2, ref["y2"][:n])
    if sc.structure == "feedforward":
        (dv,) = arrays(rows, "m_dv")
        np.testing.assert_array_equal(dv, ref["load"][:n])


def test_cascade_in_the_runtime_saturates_and_uses_the_aw_handshake():
    """The trace is not trivial: the secondary hits its limit 1.2 and the primary sees awin."""
    sc = parse_scenario(cascade())
    rows, rt = run_in_memory(sc, 300)
    (mv,) = arrays(rows, "mv")
    assert mv.max() == 1.2 and mv.min() >= 0.0
    st = rt.state("loop")
    assert st["structure"] == "cascade" and st["block"] == "PID"
    assert set(st["blocks"]) == {"primary", "secondary"}
    # the faceplate shows the secondary's setpoint = the primary's output
    assert st["signals"]["sp2"] == st["blocks"]["primary"]["out"]
    assert st["bound"]["pv2"] == "io:pv2"


def test_override_selects_the_limit_controller_then_the_main_one():
    """Åström 1987, Fig. 3.9: R2 holds x2 near 0.2 while x1 rises, then R1 takes over."""
    sc = parse_scenario(OVERRIDE)
    rows, rt = run_in_memory(sc, 400)
    pv2, pv = arrays(rows, "m_pv2", "pv")
    assert pv2.max() < 0.22
    assert pv[-1] == pytest.approx(1.0, abs=0.05)
    sig = rt.state("loop")["signals"]
    assert sig["v"] == min(sig["v1"], sig["v2"])


# -- faults on a structure's measurements ---------------------------------------------


def _secondary_fault(start: int, stop: int):
    def fault(k: int, bus: MemoryBus) -> None:  # k samples recorded so far
        if k == start:
            bus.bad.add("pv2")
        elif k == stop:
            bus.bad.discard("pv2")

    return fault


def test_bad_secondary_pv_gives_the_safe_value_in_the_same_cycle_and_recovers_bumplessly():
    sc = parse_scenario(cascade())
    start, stop = 100, 120
    rows, rt = run_in_memory(sc, 200, fault=_secondary_fault(start, stop))
    ok = [r["pv_ok"] for r in rows]
    # the first cycle that reads the bad pv2 (cycle `start`) already writes the safe value
    assert all(ok[:start]) and not any(ok[start:stop]) and all(ok[stop:])
    (mv,) = arrays(rows, "mv")
    assert mv[start - 1] > 0.3  # regulating, well away from the safe value 0.0
    assert np.all(mv[start:stop] == 0.0)
    assert all(r["error_id"] == 0x8102 for r in rows[start:stop])  # BAD_MEASUREMENT
    # bumpless: the first good cycle continues from the applied safe value (no jump back
    # to the pre-fault output) -- after an outage longer than max_dt (10 ts) as a fresh
    # start from the MV written: the secondary tracks it, the primary tracks pv2 -- and
    # afterwards the loop regulates again
    assert mv[stop] == pytest.approx(0.0, abs=1e-9)
    assert 0.0 <= mv[stop + 1] < 0.5 * mv[start - 1] and mv[stop + 5] > 0.0
    assert mv[stop + 30] > 0.3
    st = rt.state("loop")
    assert st["pv_ok"] is True


def test_bad_secondary_pv_reason_names_the_measurement():
    sc = parse_scenario(cascade())

    def fault(k: int, bus: MemoryBus) -> None:
        if k == 10:
            bus.bad.add("pv2")

    rows, rt = run_in_memory(sc, 12, fault=fault)
    reasons = rt.state("loop")["pv_reason"]
    assert reasons.startswith("pv2: ")
    assert [r["pv_ok"] for r in rows][9:] == [True, False, False]


def test_bad_disturbance_measurement_gives_the_safe_value():
    sc = parse_scenario(FEEDFORWARD)

    def fault(k: int, bus: MemoryBus) -> None:
        if k == 50:
            bus.bad.add("dv")
        elif k == 55:
            bus.bad.discard("dv")

    rows, _ = run_in_memory(sc, 80, fault=fault)
    (mv,) = arrays(rows, "mv")
    assert mv[49] != 0.0 and np.all(mv[50:55] == 0.0) and mv[56] != 0.0


# -- configuration errors ----------------------------------------------------------------

CONN = '[connections.io]\nprotocol = "memory"\n'


@pytest.mark.parametrize(
    ("edit", "key", "problem"),
    [
        (("pv2 = ", "#"), "loops[0].pv2", "missing"),
        (("secondary = {", "secondary = { ts = 0.1,"), "loops[0].secondary.ts", "once"),
        (("kp = 2.0", "kp = -2.0"), "loops[0].secondary.kp", "> 0"),
        (('structure = "cascade"', 'structure = "blend"'), "loops[0].structure", "one of"),
        (("aw_handshake = true", "aw_handshake = 1"), "loops[0].aw_handshake", "true or false"),
        (("aw_handshake = true", 'dv = "io:dv"'), "loops[0].dv", "does not read"),
    ],
)
def test_structure_config_errors_name_the_key_path(edit, key, problem):
    text = CONN + loop_tables(parse_scenario(cascade()))
    old, new = edit
    assert old in text
    with pytest.raises(RuntimeConfigError) as ei:
        parse_config(text.replace(old, new, 1), file="rt.toml")
    e = ei.value
    assert (e.file, e.key) == ("rt.toml", key) and problem in e.problem, str(e)


def test_override_needs_the_inner_measurement_its_blocks_read():
    text = CONN + loop_tables(parse_scenario(OVERRIDE))
    with pytest.raises(RuntimeConfigError) as ei:
        parse_config(text.replace('pv2 = "io:pv2"', ""))
    assert ei.value.key == "loops[0].pv2"


# -- end to end over OPC UA ---------------------------------------------------------------


@pytest.mark.loopback
@pytest.mark.slow  # end to end over OPC UA (-m slow); the in-memory tests above run by default
def test_cascade_over_opcua_equals_the_simulator_exactly(tmp_path, opcua_plant):
    from .test_loopback import history, opcua_addr

    sc = parse_scenario(cascade(ts=0.02, duration=3.0))
    n = 150
    server = fresh(*opcua_plant, PlantProcess(sc))
    loop = loop_tables(
        sc,
        pv=opcua_addr("pv"),
        pv2=opcua_addr("pv2"),
        conn="plant",
        sp=f'"plant:{opcua_addr("sp")}"',
    ).replace('mv = "plant:mv"', f'mv = "plant:{opcua_addr("mv")}"')
    text = f"""[connections.plant]
protocol = "opcua"
url = "{server.opcua_url}"
timeout = 5.0
deadline = 5.0
{loop}warn_limit = {50 * sc.ts}
alarm_limit = {100 * sc.ts}
[historian]
path = "{tmp_path / "history.sqlite"}"
flush_interval = 0.2
"""

    async def main():
        rt = Runtime(parse_config(text))
        await rt.start()
        assert rt.connections["plant"].connected  # else the lock-step trace would shift
        await wait_for(lambda: server.process.k >= n, timeout=30.0)
        await rt.stop()

    asyncio.run(main())
    rows = history(tmp_path)[:n]
    assert len(rows) == n and not any(r["overrun"] for r in rows)
    ref = simulate(sc, sc.controllers[0].name).signals
    mv = np.array([r["mv"] for r in rows])
    pv = np.array([r["pv"] if r["pv_ok"] else math.nan for r in rows])
    np.testing.assert_array_equal(mv, ref["u"][:n])
    np.testing.assert_array_equal(pv, ref["ym"][:n])
    assert mv.max() == 1.2  # the secondary saturates: the handshake is exercised


# -- end to end over Modbus ----------------------------------------------------------------


@pytest.mark.loopback
@pytest.mark.slow  # end to end over Modbus (-m slow)
@pytest.mark.parametrize(
    ("text", "n"),
    [(cascade(ts=0.02, duration=3.0), 150), (OVERRIDE, 150)],
    ids=["cascade", "override"],
)
def test_structures_over_modbus_equal_the_simulator_within_float32(tmp_path, text, n):
    """The plant server and the runtime over Modbus TCP for a cascade and an override."""
    from .test_loopback import history, modbus_addr

    sc = parse_scenario(text)

    async def main():
        server = PlantServer(PlantProcess(sc), opcua_port=None, modbus_port=0)
        await server.start()
        loop = loop_tables(
            sc,
            pv=modbus_addr("pv"),
            pv2=modbus_addr("pv2"),
            conn="plant",
            sp=f'"plant:{modbus_addr("sp")}"',
        ).replace('mv = "plant:mv"', f'mv = "plant:{modbus_addr("mv")}"')
        cfg = parse_config(f"""[connections.plant]
protocol = "modbus"
host = "127.0.0.1"
port = {server.modbus_port}
timeout = 5.0
deadline = 5.0
{loop}warn_limit = {50 * sc.ts}
alarm_limit = {100 * sc.ts}
[historian]
path = "{tmp_path / "history.sqlite"}"
flush_interval = 0.2
""")
        rt = Runtime(cfg)
        try:
            await rt.start()
            assert rt.connections["plant"].connected
            await wait_for(lambda: server.process.k >= n, timeout=60.0)
            await rt.stop()
        finally:
            await server.stop()

    asyncio.run(asyncio.wait_for(main(), 120))
    rows = history(tmp_path)[:n]
    assert len(rows) == n and not any(r["overrun"] for r in rows)
    assert all(r["pv_ok"] and r["write_ok"] for r in rows)
    ref = simulate(sc, sc.controllers[0].name).signals
    mv = np.array([r["mv"] for r in rows])
    pv = np.array([r["pv"] for r in rows])
    # FLOAT32 on the wire: values rounded to 24 bits, the loop stays on the simulator's trace
    np.testing.assert_allclose(pv, ref["ym"][:n], rtol=0, atol=1e-4)
    np.testing.assert_allclose(mv, ref["u"][:n], rtol=0, atol=1e-3)
    assert np.ptp(mv) > 0.1  # the loop did move


# -- the cascade opened by the operator (the secondary in MAN) ----------------------------


def _cascade_man(man: int, auto: int, ts: float = 0.1) -> str:
    """:func:`cascade` with the secondary in MAN from sample ``man`` to ``auto``."""
    return cascade(ts) + f"""
[[events]]
t = {man * ts}
do = "mode"
mode = "manual"
manual_value = 0.5

[[events]]
t = {auto * ts}
do = "mode"
mode = "auto"
"""


def _made(monkeypatch) -> list[Runtime]:
    """The runtimes ``run_in_memory`` makes from now on (the hooks' way to the loop)."""
    made: list[Runtime] = []

    class Recording(Runtime):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            made.append(self)

    monkeypatch.setitem(globals(), "Runtime", Recording)
    return made


def _commanded(monkeypatch, commands: dict[int, dict]):
    """``run_in_memory``'s fault hook giving operator commands before the cycles named."""
    made = _made(monkeypatch)

    def hook(k: int, bus: MemoryBus) -> None:  # k samples recorded: before cycle k
        if k in commands:
            made[-1].loops["loop"].command(**commands[k])

    return hook


def test_cascade_primary_tracks_pv2_while_the_secondary_is_in_manual(monkeypatch):
    """The operator's MAN on the secondary: the primary tracks pv2 (no windup), as simulated.

    Before the fix the primary integrated its error for the 12 s in MAN
    (the setpoint step of the scenario is not reached with the MV at 0.5).
    """
    man, auto, n = 80, 200, 300
    sc = parse_scenario(_cascade_man(man, auto))
    hook = _commanded(monkeypatch, {man: {"mode": "manual", "manual_value": 0.5},
                                    auto: {"mode": "auto"}})  # fmt: skip
    rows, rt = run_in_memory(sc, n, fault=hook)
    ref = simulate(sc, sc.controllers[0].name).signals
    mv, pv2 = arrays(rows, "mv", "m_pv2")
    np.testing.assert_array_equal(mv, ref["u"][:n])
    np.testing.assert_array_equal(pv2, ref["y2"][:n])
    assert np.all(mv[man:auto] == 0.5)
    np.testing.assert_array_equal(ref["sp2"][man:auto], ref["y2"][man:auto])
    assert abs(mv[auto] - mv[auto - 1]) < 1e-9  # bumpless back to AUTO
    # in MAN the faceplate shows the primary in AUTO with its output = pv2
    rows, rt = run_in_memory(sc, 150, fault=hook)
    st = rt.state("loop")
    assert st["blocks"]["primary"]["mode"] == "auto"
    assert st["blocks"]["secondary"]["mode"] == "manual"
    assert st["signals"]["sp2"] == st["measurements"]["pv2"]


def test_cascade_state_shows_what_the_primary_tracks(monkeypatch):
    """The faceplate's ``tracking``: the primary follows pv2 in MAN, holds on a bad pv2.

    The primary's own mode stays AUTO (the user's); ``tracking`` says that it
    does not run its law: ``{"primary": "y2"}`` while the secondary is in
    MAN, ``{"primary": "hold"}`` while pv2 is bad, ``{}`` when the cascade
    is closed.
    """
    man, auto, start, stop, n = 40, 60, 100, 120, 140
    sc = parse_scenario(cascade())
    command = _commanded(monkeypatch, {man: {"mode": "manual", "manual_value": 0.5},
                                       auto: {"mode": "auto"}})  # fmt: skip
    made = _made(monkeypatch)
    fault = _secondary_fault(start, stop)
    seen: list[tuple[dict, float, str]] = []

    def hook(k: int, bus: MemoryBus) -> None:
        st = made[-1].loops["loop"].state()  # of cycle k - 1
        seen.append((st["tracking"], st["signals"]["sp2"], st["blocks"]["primary"]["mode"]))
        command(k, bus)
        fault(k, bus)

    run_in_memory(sc, n, fault=hook)
    tracking, sp2, mode = zip(*seen, strict=True)
    assert set(mode) == {"auto"}
    assert tracking[:man] == ({},) * man
    assert tracking[man:auto] == ({"primary": "y2"},) * (auto - man)
    assert tracking[auto:start] == ({},) * (start - auto)
    assert tracking[start:stop] == ({"primary": "hold"},) * (stop - start)
    # pv2 back after more than max_dt (10 ts): one cycle of the bumpless start, in which
    # the secondary tracks the MV written and the primary pv2, then the closed cascade
    assert tracking[stop] == {"primary": "y2"}
    assert tracking[stop + 1 :] == ({},) * (n - stop - 1)
    assert set(sp2[start:stop]) == {sp2[start - 1]}  # held through the bad pv2
