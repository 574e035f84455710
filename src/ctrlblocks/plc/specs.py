"""The interface of each exported function block: names, types, initial values, comments.

This is the one hand-written part of the export besides the dialect syntax:
which parameter of a block's PLC cycle (:mod:`ctrlblocks.blocks.plc_cycle`) is
an input, an output or a state variable of the FUNCTION_BLOCK, its PLC name
and a comment.  The values come from the configured block
(``plc_cycle.pid_inputs`` / ``pid_state`` ...), the same functions the
``precision="float32"`` lane starts from; the body is translated from the
cycle function itself (:mod:`.translate`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ..blocks import ADRC, PID, LeadLag
from ..blocks import plc_cycle as pc
from ..blocks.cycleblock import CycleBlock
from ..blocks.heatcool import HeatCoolPID
from ..blocks.precision import plc_unsupported
from ..blocks.regulator import Regulator

__all__ = ["EXPORTED", "BlockSpec", "UnsupportedBlock", "spec_for"]


class UnsupportedBlock(ValueError):
    """The block (or its configuration) is not covered by the PLC export."""


@dataclass(frozen=True)
class Var:
    """One interface variable: PLC name, comment, and (python name of) its value."""

    py: str
    st: str
    comment: str


@dataclass
class BlockSpec:
    """Everything the exporter needs about one block besides its translated body."""

    kind: str
    fb_name: str
    title: str
    cycle: Callable[..., tuple[Any, ...]]
    results: tuple[str, ...]
    inputs: list[Var]
    outputs: list[Var]
    state: list[Var]
    values: dict[str, Any]
    config: Any
    process: frozenset[str] = frozenset()
    """PLC names of the inputs the process writes (the others are the configuration's)."""
    limited: tuple[str, str, str] | None = None
    """``(output, low limit input, high limit input)``: the output the block keeps inside
    the limits even when no cycle runs (python names; None: no such pair)."""

    def names(self) -> dict[str, str]:
        """python name -> PLC name for every parameter and result of the cycle."""
        return {v.py: v.st for v in (*self.inputs, *self.outputs, *self.state)}


_COMMON = {
    "ts": "sample time [s]: the cycle time of the calling task (or the measured one)",
    "error_id": "status code (ctrlblocks ErrorCode, 16#8xxx; 0 = no error)",
}
"""Comments of the variables every block has."""


def _table(text: str) -> list[Var]:
    """Interface variables from a table: ``python_name PLC_NAME comment`` a line.

    An indented line continues the comment of the line above; a row without a
    comment takes the common one (:data:`_COMMON`).
    """
    rows: list[list[str]] = []
    for line in text.strip("\n").splitlines():
        if line.startswith(" "):
            rows[-1][2] += " " + line.strip()
            continue
        py, st, *comment = line.split(maxsplit=2)
        rows.append([py, st, comment[0] if comment else _COMMON[py]])
    return [Var(*row) for row in rows]


_PID_PROCESS = _table("""
sp           SP           setpoint [{pv}]
pv           PV           process value [{pv}]
ff           FF           feed-forward / offset added before the limits [{mv}]
pv_ok        PV_OK        quality of PV; FALSE = invalid measurement (16#8102)
manual       MANUAL       manual mode: MV := MAN_VALUE (limited), bumpless back to AUTO
man_value    MAN_VALUE    manual value [{mv}]; outside MANUAL it follows MV (In/Out)
rst          RST          reset: MV := RESET_VALUE (limited), integrator set to match
dv           DV           input of the lead-lag feed-forward path (FF_K <> 0)
track        TRACK        tracking mode: MV := TRACK_VALUE (limited), bumpless back
track_value  TRACK_VALUE  output in TRACK [{mv}]
hold         HOLD         hold mode: MV stays, bumpless back
awin         AWIN         freeze the integrator (anti-windup from a secondary in cascade)
actuator_pos ACTUATOR_POS measured actuator position [{mv}] for ANTI_WINDUP = 2
                          (write it every cycle)
""")
_PID_TUNING = _table("""
k           K              gain K [{mv}/{e}] (ISA form, Åström 1987 (2.1))
ti          TI             integral time Ti [s]; 0 = no integral action
td          TD             derivative time Td [s]; 0 = no derivative action
n           N              derivative filter Tf = Td/N
b           B              setpoint weight of P (Åström 1987 (2.2))
c           C              setpoint weight of D (0 = derivative on PV)
ts          TS
u_min       U_MIN          output low limit [{mv}]
u_max       U_MAX          output high limit [{mv}]
tt          TT             tracking time constant Tt [s]; 0 = Ti/5 (ts without I)
reverse     REVERSE        reverse action
i_method    I_METHOD       integral discretisation: 0 forward (2.8), 1 backward, 2 Tustin
d_method    D_METHOD       derivative discretisation: 0 forward, 1 backward, 2 Tustin (2.13)
aw          ANTI_WINDUP    0 clamping (conditional integration), 1 back-calculation (model),
                           2 on ACTUATOR_POS
velocity    VELOCITY       TRUE: velocity (incremental) algorithm, Åström 1987 Fig. 2.5
scale_pv    SCALE_PV       TRUE: SP and PV scaled from PV_LO..PV_HI to 0..100 %
pv_lo       PV_LO          PV range low [{pv}] (SCALE_PV)
pv_hi       PV_HI          PV range high [{pv}] (SCALE_PV)
sp_filter   SP_FILTER      SP filter time constant [s] (PT1, exp(-TS/T)); 0 = off
pv_filter   PV_FILTER      PV filter time constant [s] (PT1, exp(-TS/T)); 0 = off
sp_rate     SP_RATE        setpoint ramp [{e}/s]; 0 = off
out_rate    OUT_RATE       output ramp [{mv}/s], in every mode but RST; 0 = off
ff_k        FF_K           lead-lag feed-forward gain on DV [{mv} per DV unit]; 0 = off
                           (Bonde et al. 2021)
ff_t_lead   FF_T_LEAD      feed-forward lead time constant [s]
ff_t_lag    FF_T_LAG       feed-forward lag time constant [s] (> 0, Tustin)
bumpless    BUMPLESS       to AUTO: 0 integrator, 1 track setpoint (SP ramp),
                           2 suppress P until |e| <= DEV_TOL
dev_tol     DEV_TOL        deviation tolerance [{e}] of BUMPLESS = 2
reset_value RESET_VALUE    output while RST [{mv}]
safe_value  SAFE_VALUE     output while SP/PV/FF are bad, if USE_SAFE_VALUE [{mv}]
use_safe    USE_SAFE_VALUE TRUE: SAFE_VALUE on bad inputs; FALSE: hold MV
db_width    DEADBAND       adaptive dead band half-width [{e}] (controltheplant 2024,
                           2.3.10); 0 = off
t_stab      T_STAB         stabilisation time [s] of the dead band: the error inside the band
                           for T_STAB holds MV at its mean over T_STAB/TS samples (<= the
                           exported array; a longer one: 16#8209, the window in force stays)
i_band      I_BAND         integral band [%]: the error is integrated only while |E| <= I_BAND
                           (conditional integration); 0 = always
""")
_PID_OUT = _table("""
mv            MV            manipulated variable [{mv}] (limited)
error_id      ERROR_ID
limits_active LIMITS_ACTIVE the output is at a limit (= AWOUT for a cascade)
p             P             proportional term [{mv}] of the last cycle that ran the law (a
                            cycle that holds on bad input keeps it)
i_term        I_TERM        integral term [{mv}] (as P)
d_term        D_TERM        derivative term [{mv}] (as P)
""")
_PID_STATE_COMMENTS = {
    "out": "output of the last cycle [{mv}]", "i": "integrator for the next cycle [{mv}]",
    "d": "derivative state D[k-1]", "w_prev": "c r - y of the last cycle",
    "e_prev": "control error of the last cycle", "lo": "low limit in force",
    "hi": "high limit in force", "mode_prev": "mode of the last cycle (-1 none, 0 auto)",
    "cold": "first cycle after a (re)start", "reinit": "re-initialise the integrator",
    "reinit_d": "re-initialise the derivative histories",
    "x": "output integrator of the velocity algorithm [{mv}]",
    "bias": "bias of the velocity algorithm without I (Åström 1987, Fig. 2.4)",
    "p_prev": "P of the last cycle (velocity)", "d_prev": "D of the last cycle (velocity)",
    "ff_prev": "FF of the last cycle (velocity)", "sp_f": "filtered SP", "pv_f": "filtered PV",
    "sp_w": "working setpoint after the ramp", "ll_x": "DV of the last cycle",
    "ll_out": "output of the lead-lag feed-forward", "suppressed": "P action suppressed",
    "ramp_out": "output ramp's last value [{mv}]",
    "db_active": "the dead band holds the output", "db_hold": "output held by the dead band [{mv}]",
    "db_win": "moving-average window in force [samples]", "db_t": "T_STAB in force [s]",
    "st_anchor": "dead band's steady-state detector: its anchor",
    "st_elapsed": "dead band's steady-state detector: time inside the band [s]",
    "st_started": "dead band's steady-state detector: anchor set",
}  # fmt: skip

_ADRC_PROCESS = _table("""
sp     SP        setpoint Y_sp [{pv}]
y      PV        process value Y [{pv}]
ff     FF        feed-forward [{mv}], added before the limits; the ESO is fed the applied u
                 less it (a NaN holds MV as a bad SP, 16#8101)
y_ok   PV_OK     quality of PV (y_ok, Nowak et al. 2018 section 5); FALSE: MV := U_SF
manual MANUAL    MAN mode (A_M): MV := MAN_VALUE, x4 re-solved by (11)
u_man  MAN_VALUE manual value [{mv}]; outside MANUAL it follows the applied u (In/Out)
track  TRACK     TRACK mode (priority TRACK > HOLD > MANUAL): MV := TRACK_VALUE, bumpless back
track_value TRACK_VALUE tracking value [{mv}] (NaN: the last MV, 16#8101)
hold   HOLD      HOLD mode: MV := the last applied u, bumpless back
rst    RST       RESET mode (priority over all): MV := RESET_VALUE (limited) at once, past
                 OUT_RATE; the law tracks it, bumpless back
awin   AWIN      freeze x4 (anti-windup from a secondary in cascade, section 5)
u_real U_REAL    measured actuator value u_real [{mv}] (U_REAL_ON; NaN: u, 16#8101)
""")
_ADRC_TUNING = _table("""
order        ORDER        ADRC order n = 1, 2, 3 (one body for all, section 3.2)
b0           B0           scaling parameter b0 > 0 [{pv}/s^n per {mv}] (n = ORDER)
omega_c      OMEGA_C      controller bandwidth [rad/s]
omega_o      OMEGA_O      observer bandwidth [rad/s]
ts           TS
u_min        U_MIN        lower limit of MV [{mv}]
u_max        U_MAX        upper limit of MV [{mv}]
t_ref        T_REF        time constant of the reference trajectory [s]; 0 = off
u_sf         U_SF         safe value while PV is invalid [{mv}]
aw_rule      ANTI_WINDUP  x4 anti-windup: 0 off, 1 freeze, 2 directional (section 4.1)
exact        EXACT        TRUE: exact (ZOH) current observer, FALSE: Euler ESO (4a)
u_real_on    U_REAL_ON    TRUE: U_REAL drives the ESO (section 5)
anti_backoff ANTI_BACKOFF anti-backoff action (12a)/(12b) at a sensor limit (4.3)
y_sat        Y_SAT        upper saturation of the sensor [{pv}] (ANTI_BACKOFF)
y_sat_lo     Y_SAT_LO     lower saturation of the sensor [{pv}] (ANTI_BACKOFF)
tau_wait     TAU_WAIT     hold of u after leaving the saturation [s]; 0 = 3.5/OMEGA_O
reverse      REVERSE      reverse-acting process (negative gain): the ESO and law run on -SP, -Y
out_rate     OUT_RATE     largest change of MV per second [{mv}/s], in every mode; 0 = off
u0           RESET_VALUE  output while RST [{mv}] (the block's u0)
scale_pv     SCALE_PV     TRUE: SP and PV (and Y_SAT, Y_SAT_LO) scaled from PV_LO..PV_HI to
                          0..100 %; B0 then in %/s^n per {mv}
pv_lo        PV_LO        PV range low [{pv}] (SCALE_PV)
pv_hi        PV_HI        PV range high [{pv}] (SCALE_PV)
sp_filter    SP_FILTER    SP filter time constant [s] (PT1, exp(-TS/T)); 0 = off
pv_filter    PV_FILTER    PV filter time constant [s] (PT1, exp(-TS/T)); 0 = off
sp_rate      SP_RATE      setpoint ramp [{pv}/s, %/s with SCALE_PV]; 0 = off
td_time      TD_TIME      tracking differentiator time constant [s]: ORDER lags on the working SP,
                          their derivatives fed forward in (4b); 0 = off (not with T_REF)
nd           DELAY        dead time of the process input [samples of TS] (input_delay/ts): the ESO
                          is fed the applied u of DELAY samples before the last (Zhao & Gao 2014);
                          at most the exported array (a longer one: 16#8211, the one in force stays)
""")
_ADRC_OUT = _table("""
mv       MV          manipulated variable u [{mv}] (limited)
error_id ERROR_ID
awout    AWOUT       u_raw beyond a limit (for a primary controller in cascade)
u_raw    U_RAW       u of the control law (4b) before the limits [{mv}]
x4_out   DISTURBANCE x4: estimate of the total disturbance h [{pv}/s^n]
e_out    E           control error SP - PV [{pv}] (Fig. 2, e)
y_out    Y           the measurement used [{pv}] (Fig. 2, Y)
y_ref    Y_REF       the reference trajectory [{pv}] (Fig. 2, Y_ref; the law adds the handover
                     offset Q)
x1_out   X1          ESO state Y_hat [{pv}] (Fig. 2, observer state; with REVERSE in the units
                     of -PV)
x2_out   X2          ESO state x2 [{pv}/s] (the first derivative of Y in the model; 0 for n = 1)
x3_out   X3          ESO state x3 [{pv}/s^2] (the second derivative of Y in the model; 0 for
                     n < 3)
sp_td    SP_TD       the tracking differentiator's filtered SP r_f [{pv}] (TD_TIME; else the
                     working SP)
""")
_ADRC_STATE_COMMENTS = {
    "out": "u of the last cycle [{mv}]", "yh": "ESO state Y_hat [{pv}]", "x2": "ESO state x2",
    "x3": "ESO state x3", "x4": "ESO state x4 (total disturbance)",
    "u_prev": "applied u of the last cycle [{mv}]", "ref": "reference trajectory [{pv}]",
    "ff_prev": "FF of the last cycle [{mv}] (the ESO is fed U_PREV - FF_PREV)",
    "q": "handover offset of the reference [{pv}] (bumpless transfer, decays by "
         "EXP(-OMEGA_C TS))",
    "e": "control error of the last valid cycle [{pv}]",
    "y_last": "PV of the last valid cycle [{pv}]",
    "started": "the ESO has been started on a valid PV", "resolve": "re-solve x4 by (11)",
    "sat": "+1/-1: last u_raw above/below the limits", "lo": "low limit in force",
    "hi": "high limit in force", "ab_sat": "+1/-1: Y at the upper/lower sensor saturation",
    "ab_wait": "anti-backoff hold time left [s]",
    "rev_prev": "REVERSE of the last cycle (a change negates the states)",
    "d_restart": "the delay line restarts at the output (after an overflow)",
    "sp_f": "filtered SP", "pv_f": "filtered PV (the Y the ESO sees)",
    "sp_w": "working setpoint after the ramp", "scale_prev": "SCALE_PV of the last cycle",
    "pv_lo_prev": "PV_LO of the last cycle", "pv_hi_prev": "PV_HI of the last cycle",
    "td1": "tracking differentiator: first lag [{pv}]", "td2": "second lag [{pv}]",
    "td3": "third lag [{pv}]", "td_time_prev": "TD_TIME of the last cycle (a change restarts "
    "the chain)",
}  # fmt: skip

_LL_PROCESS = _table("""
x      IN     input (setpoint or measured disturbance) [{pv}]
enable ENABLE FALSE: OUT := 0, the input follows IN (Bonde et al. 2021, Fig. 10)
""")
_LL_TUNING = _table("""
k       K       gain K [{mv}/{pv}]
t_lead  T_LEAD  lead time constant Tt [s] (numerator)
t_lag   T_LAG   lag time constant Tn [s] (denominator)
ts      TS
tustin  TUSTIN  TRUE Tustin (Bonde et al. 2021, Fig. 10), FALSE backward Euler
out_min OUT_MIN output low limit [{mv}]
out_max OUT_MAX output high limit [{mv}]
""")
_LL_OUT = _table("""
out      OUT      output K (1 + Tt s)/(1 + Tn s), limited [{mv}]
error_id ERROR_ID
""")


def _state(values: dict[str, Any], comments: dict[str, str], skip: set[str]) -> list[Var]:
    return [Var(k, k, comments.get(k, "previous tuning (a change is bumpless)"))
            for k in values if k not in skip]  # fmt: skip


def _units(kind: str, config: Any, units: Mapping[str, str] | None) -> dict[str, str]:
    """The unit texts of the comments: ``pv`` (SP, PV), ``mv`` (the output), ``e`` (the
    control error: % of the PV range when the PID scales PV, else PV's unit).  Unknown units
    are named, not guessed (``[MV unit/PV unit]``)."""
    given = {k: v for k, v in (units or {}).items() if v}
    if kind == "leadlag":
        return {"pv": given.get("pv", "IN unit"), "mv": given.get("mv", "OUT unit")}
    pv = given.get("pv", given.get("sp", "PV unit"))
    scaled = kind == "pid" and config.pv_range is not None
    return {"pv": pv, "mv": given.get("mv", "MV unit"), "e": "% of PV range" if scaled else pv}


def _with_units(spec: BlockSpec, units: dict[str, str]) -> BlockSpec:
    def fill(vs: list[Var]) -> list[Var]:
        return [Var(v.py, v.st, v.comment.format_map(units)) for v in vs]

    spec.inputs, spec.outputs, spec.state = fill(spec.inputs), fill(spec.outputs), fill(spec.state)
    return spec


def spec_for(block: Any, units: Mapping[str, str] | None = None) -> BlockSpec:
    """The :class:`BlockSpec` of a configured PID, ADRC or LeadLag.

    ``units``: the unit of ``"pv"`` (SP and PV) and ``"mv"`` (the output) for the comments
    (a runtime TOML's ``unit`` table); unknown units are written as ``PV unit``, ``MV unit``.
    """
    spec = _spec_for(block)
    return _with_units(spec, _units(spec.kind, block.config, units))


def _spec_for(block: Any) -> BlockSpec:
    c = block.config
    if isinstance(block, PID):
        bad = plc_unsupported(c, "pid")
        if bad:
            raise UnsupportedBlock(f"the PLC export does not cover the PID options {bad}")
        state = pc.pid_state(c)
        process = {"sp": 0.0, "pv": 0.0, "ff": 0.0, "pv_ok": True, "manual": False,
                   "man_value": state["out"], "rst": False, "dv": 0.0, "track": False,
                   "track_value": 0.0, "hold": False, "awin": False,
                   "actuator_pos": 0.0}  # fmt: skip
        outputs = {"mv": state["out"], "error_id": 0, "limits_active": False, "p": 0.0,
                   "i_term": state["i"], "d_term": 0.0}  # fmt: skip
        values = {**process, **pc.pid_inputs(c), **state, **outputs}
        return BlockSpec("pid", "CB_PID", "PID (ISA form, positional or velocity)", pc.pid_cycle,
                         pc.PID_RESULTS, _PID_PROCESS + _PID_TUNING, _PID_OUT,
                         _state(state, _PID_STATE_COMMENTS, {"p", "i_term"}), values, c,
                         frozenset(v.st for v in _PID_PROCESS),
                         ("mv", "u_min", "u_max"))  # fmt: skip
    if isinstance(block, ADRC):
        bad = plc_unsupported(c, "adrc")
        if bad:
            raise UnsupportedBlock(f"the PLC export does not cover the ADRC options {bad}")
        state = pc.adrc_state(c)
        process = {"sp": 0.0, "y": 0.0, "ff": 0.0, "y_ok": True, "manual": False,
                   "u_man": state["out"], "track": False, "track_value": 0.0, "hold": False,
                   "rst": False, "awin": False, "u_real": 0.0}  # fmt: skip
        values = {**process, **pc.adrc_inputs(c), **state, "mv": state["out"], "error_id": 0,
                  "awout": False, "u_raw": state["out"], "x4_out": 0.0, "e_out": 0.0,
                  "y_out": 0.0, "y_ref": 0.0, "x1_out": 0.0, "x2_out": 0.0, "sp_td": 0.0,
                  "x3_out": 0.0}  # fmt: skip
        return BlockSpec("adrc", "CB_ADRC", "ADRC (Euler or exact ESO, orders 1..3)", pc.adrc_cycle,
                         pc.ADRC_RESULTS, _ADRC_PROCESS + _ADRC_TUNING, _ADRC_OUT,
                         _state(state, _ADRC_STATE_COMMENTS, set()), values, c,
                         frozenset(v.st for v in _ADRC_PROCESS),
                         ("mv", "u_min", "u_max"))  # fmt: skip
    if isinstance(block, LeadLag):
        state = pc.leadlag_state(c)
        values = {"x": 0.0, "enable": True, **pc.leadlag_inputs(c), **state, "error_id": 0}
        return BlockSpec("leadlag", "CB_LEADLAG", "lead-lag K (1 + Tt s)/(1 + Tn s)",
                         pc.leadlag_cycle, pc.LEADLAG_RESULTS, _LL_PROCESS + _LL_TUNING,
                         _LL_OUT, _state(state, {"x_prev": "input of the last sample",
                                                 "lo": "low limit in force",
                                                 "hi": "high limit in force"}, {"out"}),
                         values, c, frozenset(v.st for v in _LL_PROCESS),
                         ("out", "out_min", "out_max"))  # fmt: skip
    cycle_spec = _cycle_block_spec(block)
    if cycle_spec is not None:
        return cycle_spec
    raise UnsupportedBlock(
        f"no PLC export for {type(block).__name__}; blocks exported: {', '.join(EXPORTED)}"
    )


# ---------------------------------------------------------------------------
# Blocks run by one pure cycle function (blocks.cycleblock.CycleBlock)
# ---------------------------------------------------------------------------

_ONOFF_PROCESS = _table("""
sp     SP     setpoint [{pv}]
pv     PV     process value [{pv}]
pv_ok  PV_OK  quality of PV; FALSE = invalid measurement (16#8102): the output goes off
enable ENABLE FALSE: the output goes off (no error)
""")
_ONOFF_TIMES = _table("""
reverse   REVERSE   FALSE: e = SP - PV (heating: on below SP); TRUE: e = PV - SP (cooling)
t_min_on  T_MIN_ON  minimum on time [s]
t_min_off T_MIN_OFF minimum off time [s]
ts        TS
""")
_TWO_POINT = (
    "CB_TWOPOINT", "two-point controller with hysteresis (Beckhoff TF4100 FB_CTRL_2POINT)",
    _ONOFF_PROCESS + _table("""
hysteresis HYSTERESIS hysteresis width H [{pv}]: switching points SP - H/2 and SP + H/2
""") + _ONOFF_TIMES,
    _table("""
out      OUT      1.0 on, 0.0 off
error_id ERROR_ID
"""),
    {"on": "the output is on (the relay)", "t_in": "time in the present state [s]"},
)
_THREE_POINT = (
    "CB_THREEPOINT", "three-point controller raise/stop/lower (Beckhoff TF4100 FB_CTRL_3POINT)",
    _ONOFF_PROCESS + _table("""
deadband   DEADBAND   neutral zone half-width D [{pv}]: +1 from SP - PV >= D, -1 from <= -D
hysteresis HYSTERESIS hysteresis H of each switching point [{pv}] (0 <= H <= 2 D)
""") + _ONOFF_TIMES,
    _table("""
out       OUT       +1.0 raise, 0.0 stop, -1.0 lower
error_id  ERROR_ID
raise_out RAISE_OUT the raise relay
lower_out LOWER_OUT the lower relay
"""),
    {"state": "+1 raise, 0 stop, -1 lower", "t_in": "time in the present state [s]"},
)
_TRANSFER = (
    "CB_TRANSFER", "discrete transfer function, a cascade of biquads (transposed direct form II)",
    _table("""
x       X       input
init    INIT    TRUE: start at rest at this input (output = DC gain x X)
b0      B0      numerator coefficient b0 of each section
b1      B1      numerator coefficient b1 of each section (of z^-1)
b2      B2      numerator coefficient b2 of each section (of z^-2)
a1      A1      denominator coefficient a1 of each section (of z^-1; a0 = 1)
a2      A2      denominator coefficient a2 of each section (of z^-2)
out_min OUT_MIN output low limit
out_max OUT_MAX output high limit
"""),
    _table("""
out      OUT      output, limited
error_id ERROR_ID
"""),
    {"y": "unlimited output of the last valid sample", "z1": "memory s1 of each section",
     "z2": "memory s2 of each section"},
)
_SETPOINT = (
    "CB_SETPOINT", "setpoint programmer: ramp/soak segments with guaranteed ramp and soak",
    _table("""
pv            PV            process value [{pv}] (holdback and start at PV)
pv_ok         PV_OK         quality of PV; FALSE holds the program while a holdback band is on
run           RUN           TRUE: the program runs; FALSE: it holds where it is
reset         RESET         TRUE: back to the start (START or PV, segment 0)
target        TARGET        target of each segment [{pv}]
rate          RATE          ramp rate of each segment [{pv}/s]; 0 = a step
soak          SOAK          soak time of each segment [s]
start         START         setpoint at the start [{pv}]
start_at_pv   START_AT_PV   TRUE: start at the PV instead (when it is valid)
repeat        CYCLIC        TRUE: after the last segment start again with the first
holdback_ramp HOLDBACK_RAMP guaranteed ramp: hold while |PV - SP| exceeds it; 0 = off
holdback_soak HOLDBACK_SOAK guaranteed soak: hold while |PV - SP| exceeds it; 0 = off
ts            TS
"""),
    _table("""
out      OUT      setpoint [{pv}]
error_id ERROR_ID
held     HELD     a holdback band holds the program
"""),
    {"seg": "segment (0-based)", "phase": "0 ramp, 1 soak", "done": "the program has ended",
     "sp": "setpoint", "t_soak": "soak time spent [s]", "started": "the program has started"},
)
_HEAT_COOL = (
    "CB_HEATCOOL", "heat/cool output stage of HeatCoolPID: split, parameter set, PWM on both "
    "outputs (wire CB_PID.MV to V)",
    _table("""
v                 V                 the PID's demand [%] (CB_PID.MV): > 0 heats, < 0 cools
deadzone          DEADZONE          neutral zone [%] between heating and cooling
factor            COOL_FACTOR       cooling factor: heating actuator gain / cooling actuator gain
switching         SWITCHING         TRUE: own cooling tunings, chosen by COOLING
switch_hysteresis SWITCH_HYSTERESIS hysteresis [%] of the switch between the parameter sets
pwm               PWM               TRUE: both outputs pulse-width modulated (0 or 100 %)
period            PERIOD            PWM period [s]
t_min_on          T_MIN_ON          shortest PWM pulse [s]
t_min_off         T_MIN_OFF         shortest PWM pause [s]
ts                TS
"""),
    _table("""
out         OUT      HEAT - COOL [%]
error_id    ERROR_ID
heat        HEAT     heating output [%] (0 or 100 with PWM)
cool        COOL     cooling output [%] (0 or 100 with PWM)
cooling_out COOLING  TRUE: give CB_PID the cooling tunings in the next cycle
"""),
    {"cooling": "the parameter set chosen (cooling)", "h_on": "heating PWM on",
     "c_on": "cooling PWM on"},
)
_REGULATOR_PROCESS = _table("""
pid_mv    PID_MV    CB_PID.MV of the last cycle [{mv}] (the regulator's output): the output
                    station tracks it in AUTO (not a finite REAL: it holds, 16#8101)
sp_remote SP_REMOTE external (remote) setpoint [{pv}]; not a finite REAL while REMOTE: SP holds
                    (16#8101)
auto      AUTO      switch 2: TRUE automatic (the PID's output), FALSE manual (the output
                    station's, moved by OUT_INC/OUT_DEC); both ways bumpless
remote    REMOTE    switch 1: TRUE SP := SP_REMOTE, FALSE the local setpoint station (moved by
                    SP_INC/SP_DEC; it tracks SP_REMOTE while REMOTE: bumpless back to local)
sp_inc    SP_INC    raise button of the local setpoint (held = TRUE; accelerates)
sp_dec    SP_DEC    lower button of the local setpoint
out_inc   OUT_INC   raise button of the output in manual
out_dec   OUT_DEC   lower button of the output in manual
""")
_REGULATOR = (
    "CB_REGULATOR", "stations and switches of the complete regulator, Åström 1987, Fig. 4.6 "
    "(call before CB_PID; wire SP, MANUAL, MAN_VALUE to it and CB_PID.MV to PID_MV)",
    _REGULATOR_PROCESS + _table("""
sp_min    SP_MIN    local setpoint low limit [{pv}]
sp_max    SP_MAX    local setpoint high limit [{pv}]
u_min     U_MIN     output low limit [{mv}] (write CB_PID.U_MIN alike)
u_max     U_MAX     output high limit [{mv}] (write CB_PID.U_MAX alike)
tm_sp     TM_SP     manual time constant Tm [s] of the setpoint station: SP_MAX - SP_MIN in
                    TM_SP at the base rate (Åström 1987, Fig. 4.5)
tm_out    TM_OUT    manual time constant Tm [s] of the output station: U_MAX - U_MIN in TM_OUT
t_accel   T_ACCEL   a held button's rate grows by one base rate every T_ACCEL [s]
accel_max ACCEL_MAX largest rate / base rate (1 = no acceleration)
tr        TR        tracking time constant Tr [s] of the idle station (Åström 1987,
                    Fig. 4.5); 0 = ideal tracking (exactly bumpless)
ts        TS
"""),
    _table("""
sp_out    SP        working setpoint [{pv}]: write it to CB_PID.SP
manual    MANUAL    NOT AUTO: write it to CB_PID.MANUAL (the PID tracks the station)
man_value MAN_VALUE output station [{mv}]: write it to CB_PID.MAN_VALUE
error_id  ERROR_ID
"""),
    {"sp_w": "working setpoint [{pv}]", "sp_v": "local setpoint station [{pv}]",
     "sp_held": "time the setpoint button has been held [s]",
     "sp_dir": "setpoint button of the last cycle: +1, -1, 0", "u_v": "output station [{mv}]",
     "u_held": "time the output button has been held [s]",
     "u_dir": "output button of the last cycle: +1, -1, 0",
     "follow": "the last cycle was automatic: the output station tracks PID_MV",
     "h_prev": "TS of the last cycle [s]", "sp_lo": "setpoint low limit in force",
     "sp_hi": "setpoint high limit in force", "u_lo": "output low limit in force",
     "u_hi": "output high limit in force", "tm_sp_f": "TM_SP in force",
     "tm_out_f": "TM_OUT in force", "t_accel_f": "T_ACCEL in force",
     "accel_max_f": "ACCEL_MAX in force", "tr_f": "TR in force"},
)  # fmt: skip
_CYCLE_PROCESS = {
    "HeatCoolPID": ("V",),
    "Regulator": tuple(v.st for v in _REGULATOR_PROCESS),
    "SetpointProgram": ("PV", "PV_OK", "RUN", "RESET"),
    "TwoPoint": tuple(v.st for v in _ONOFF_PROCESS),
    "ThreePoint": tuple(v.st for v in _ONOFF_PROCESS),
    "TransferFunction": ("X", "INIT"),
}
"""Class name -> PLC names of the inputs the process writes (the others are the
configuration's: the hostile runs retune them)."""
_CYCLE_BLOCKS: dict[str, tuple[str, str, list[Var], list[Var], dict[str, str]]] = {
    "HeatCoolPID": _HEAT_COOL,
    "Regulator": _REGULATOR,
    "SetpointProgram": _SETPOINT,
    "TwoPoint": _TWO_POINT,
    "ThreePoint": _THREE_POINT,
    "TransferFunction": _TRANSFER,
}
"""Class name -> (FB name, title, inputs, outputs, state comments) of each cycle block."""
EXPORTED = ("PID", "ADRC", "LeadLag", *sorted(_CYCLE_BLOCKS))
"""The class names of the blocks the PLC export covers."""


def _cycle_block_spec(block: Any) -> BlockSpec | None:
    """The :class:`BlockSpec` of a block run by one cycle function, or None."""
    entry = _CYCLE_BLOCKS.get(type(block).__name__)
    if entry is None or not isinstance(block, CycleBlock | HeatCoolPID | Regulator):
        return None
    fb_name, title, inputs, outputs, comments = entry
    values = block.plc_values()
    state = [Var(k, k, comments.get(k, "")) for k in block.memory_names()]
    return BlockSpec(type(block).__name__.lower(), fb_name, title, block.cycle_function(),
                     block.cycle_results(), inputs, outputs, state, values,
                     block.config, frozenset(_CYCLE_PROCESS[type(block).__name__]))  # fmt: skip
