"""The ``[[loops]]`` table: a loop's structure, blocks, bindings, fault and time settings.

:class:`LoopTables` is the part of the configuration parser (:mod:`.parser`)
that reads one loop; every error names the key path (``loops[1].block.kp``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ...loops.spec import ControllerSpec
from ...loops.structures import STRUCTURES as _STRUCTURES
from ...loops.structures import parse_controller
from ...loops.toml import NAME_RE
from ..health import alarm_output_problem, check_health_tables
from .engineering import ENGINEERING_KEYS, engineering
from .model import (
    MAX_DT_TS,
    MEASUREMENTS,
    STRUCTURES,
    Binding,
    ConnectionConfig,
    LoopConfig,
    RuntimeConfigError,
)
from .protocols import PROTOCOLS

__all__ = ["LoopTables"]

_FAULT_LOOP_KEYS = ("on_fault", "hold_time")
_TIME_LOOP_KEYS = ("on_late", "max_dt", "initial_mv", "start")


class LoopTables:
    """Reading one ``[[loops]]`` entry (a part of the configuration parser)."""

    # provided by the parser (TableReader and .parser._Parser)
    fail: Any
    as_table: Any
    choice: Any
    string: Any
    number: Any
    integer: Any
    check_keys: Any
    binding: Any
    file: str

    def loop(self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig]) -> LoopConfig:
        raw = self.as_table(raw, key)
        structure = self.choice(raw, "structure", f"{key}.structure", tuple(STRUCTURES), "single")
        allowed = {
            "name",
            "ts",
            "structure",
            "pv",
            "pv2",
            "dv",
            "wild",
            "mv",
            "mv2",
            "sp",
            "mode",
            "manual_value",
            "u_min",
            "u_max",
            "safe_value",
            "stop_value",
            "on_bad_pv",
            "warn_limit",
            "alarm_limit",
            "write_retries",
            "u0",
            "alarms",
            "assess",
            "alarm_outputs",
            *_FAULT_LOOP_KEYS,
            *_TIME_LOOP_KEYS,
            *ENGINEERING_KEYS,
            *STRUCTURES[structure],
            *_STRUCTURES[structure].output_tags,
        }
        self.check_keys(raw, allowed, key)
        name = self.string(raw, "name", f"{key}.name")
        if not NAME_RE.match(name):
            raise self.fail(f"{key}.name", "loop names are letters, digits, _ . - only")
        ts = self.number(raw, "ts", f"{key}.ts", positive=True)
        st = _STRUCTURES[structure]
        used = st.measurements_in(raw)
        needs = tuple(sig for sig, m in MEASUREMENTS.items() if m in used)
        for sig in ("pv", "pv2", "dv", "wild"):
            if sig in raw and sig not in needs:
                raise self.fail(
                    f"{key}.{sig}",
                    f"the {structure} structure does not read {sig} (reads: {', '.join(needs)})",
                )
        optional = {s for s, m in MEASUREMENTS.items() if m in st.optional_measurements}
        needs = tuple(s for s in needs if s not in optional or s in raw)
        for sig in (*needs, "mv"):
            if sig not in raw:
                raise self.fail(f"{key}.{sig}", 'missing (an I/O address "CONNECTION:ADDRESS")')
        meas = {sig: self.binding(raw[sig], f"{key}.{sig}", conns) for sig in needs}
        mv = self.binding(raw["mv"], f"{key}.mv", conns)
        mv2 = self.second_mv(raw, key, structure, conns, mv)
        outputs = self.output_tags(raw, key, st.output_tags, conns, mv)
        for sig, b in (*meas.items(), ("mv", mv)):
            if not b.is_io:
                raise self.fail(f"{key}.{sig}", 'must be an I/O address "CONNECTION:ADDRESS"')
        if "sp" not in raw:
            raise self.fail(f"{key}.sp", 'missing (a number or "CONNECTION:ADDRESS")')
        sp = self.binding(raw["sp"], f"{key}.sp", conns)
        mode = self.binding(raw.get("mode", "auto"), f"{key}.mode", conns, mode=True)
        opt = {}
        for sig in ("manual_value", "u_min", "u_max"):
            opt[sig] = self.binding(raw[sig], f"{key}.{sig}", conns) if sig in raw else None
        if (opt["u_min"] is None) != (opt["u_max"] is None):
            raise self.fail(f"{key}.u_min", "bind u_min and u_max together (or neither)")
        for sig in ("u_min", "u_max"):
            if opt[sig] is not None and not opt[sig].is_io:
                raise self.fail(
                    f"{key}.{sig}", "constant limits belong in the block table (block.u_min ...)"
                )
        if "safe_value" not in raw:
            raise self.fail(
                f"{key}.safe_value",
                "missing: the MV on a measurement fault and on stop (a number) is required",
            )
        safe = self.number(raw, "safe_value", f"{key}.safe_value")
        if not math.isfinite(safe):
            raise self.fail(f"{key}.safe_value", "must be finite")
        stop = self.number(raw, "stop_value", f"{key}.stop_value", None)
        if stop is not None and not math.isfinite(stop):
            raise self.fail(f"{key}.stop_value", "must be finite")
        u0 = self.number(raw, "u0", f"{key}.u0", 0.0)
        if not math.isfinite(u0):
            raise self.fail(f"{key}.u0", "must be finite")
        # the blocks that write the MV get the loop's safe value
        mv_tables = self.mv_tables(raw, key, structure)
        types = {self.string(t, "type", f"{k}.type") for k, t in mv_tables}
        on_bad = self.choice(
            raw,
            "on_bad_pv",
            f"{key}.on_bad_pv",
            ("safe",) if "ADRC" in types else ("safe", "hold"),
            "safe",
        )
        patched: dict[str, dict[str, Any]] = {}
        for k, table in mv_tables:
            btype = self.string(table, "type", f"{k}.type")
            if btype not in ("PID", "ADRC"):
                raise self.fail(f"{k}.type", f"the runtime runs PID or ADRC, got {btype!r}")
            if "ts" in table:
                raise self.fail(f"{k}.ts", "set the sample time once, as the loop's ts")
            params = {n: v for n, v in table.items()}
            if btype == "ADRC":
                if "u_sf" in params:
                    raise self.fail(f"{k}.u_sf", "set the loop's safe_value instead")
                params["u_sf"] = safe
            else:
                if "safe_value" in params:
                    raise self.fail(
                        f"{k}.safe_value", "set the loop's safe_value and on_bad_pv instead"
                    )
                params["safe_value"] = safe if on_bad == "safe" else None
            patched[k] = params
        controller: ControllerSpec | None = None
        if _STRUCTURES[structure].lone_block:
            params = dict(patched[f"{key}.block"])
            btype = params.pop("type")
        else:
            controller = self.structure_entry(raw, key, structure, ts, name, patched)
            if stop is not None and st.off_mv(controller) is not None:
                raise self.fail(
                    f"{key}.stop_value",
                    f"a {structure} loop stops its output stage at its off state "
                    f"(MV {st.off_mv(controller)!r}); there is no stop value to give",
                )
            main_key = mv_tables[0][0]
            btype = patched[main_key]["type"]
            params = {n: v for n, v in patched[main_key].items() if n != "type"}
        warn = self.number(raw, "warn_limit", f"{key}.warn_limit", None)
        alarm = self.number(raw, "alarm_limit", f"{key}.alarm_limit", None)
        for n, v in (("warn_limit", warn), ("alarm_limit", alarm)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise self.fail(f"{key}.{n}", f"must be a finite number > 0, got {v!r}")
        w, a = (warn if warn is not None else 1.5 * ts), (alarm if alarm is not None else 2 * ts)
        if alarm is None and a < w:
            alarm = a = w  # the default alarm limit (2 ts) never undercuts the warning limit
        if a < w:
            raise self.fail(f"{key}.alarm_limit", f"must be >= warn_limit ({w!r})")
        retries = self.integer(raw, "write_retries", f"{key}.write_retries", 1, 0)
        health = check_health_tables(raw, key, ts, self.fail)
        taken = {"mv": mv, "mv2": mv2, **outputs, **meas, "sp": sp, "mode": mode, **opt}
        alarm_outputs = self.alarm_outputs(raw, key, conns, mv, health, taken)
        return LoopConfig(
            name=name,
            ts=ts,
            block_type=btype,
            block_params=params,
            pv=meas.get("pv"),  # type: ignore[arg-type]
            mv=mv,
            sp=sp,
            mode=mode,
            manual_value=opt["manual_value"],
            u_min=opt["u_min"],
            u_max=opt["u_max"],
            safe_value=safe,
            stop_value=stop,
            on_bad_pv=on_bad,
            warn_limit=warn,
            alarm_limit=alarm,
            write_retries=retries,
            key=key,
            structure=structure,
            controller=controller,
            pv2=meas.get("pv2"),
            dv=meas.get("dv"),
            u0=u0,
            mv2=mv2,
            wild=meas.get("wild"),
            outputs=outputs,
            health=health,
            alarm_outputs=alarm_outputs,
            **self.fault_action(raw, key),
            **self.time_settings(raw, key, ts),
            **engineering(self, raw, key, sp, opt["manual_value"]),
        )

    def second_mv(
        self,
        raw: Mapping[str, Any],
        key: str,
        structure: str,
        conns: Mapping[str, ConnectionConfig],
        mv: Binding,
    ) -> Binding | None:
        """``mv2``: actuator B of a split range, on the MV's connection (one batched write)."""
        if _STRUCTURES[structure].actuators < 2:
            if "mv2" in raw:
                raise self.fail(
                    f"{key}.mv2", f"the {structure} structure writes one MV (mv2: split_range)"
                )
            return None
        if "mv2" not in raw:
            raise self.fail(
                f"{key}.mv2",
                'missing: the split range\'s second actuator (an I/O address "CONNECTION:ADDRESS")',
            )
        mv2 = self.written_with_mv(
            raw["mv2"], f"{key}.mv2", conns, mv, "both actuators are written in one batched request"
        )
        if mv2.address == mv.address:
            raise self.fail(f"{key}.mv2", f"is the address of mv ({mv}); give actuator B's own")
        return mv2

    def written_with_mv(
        self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig], mv: Binding, why: str
    ) -> Binding:
        """An output address written with the MV: I/O, on the MV's connection (``why``)."""
        b = self.binding(raw, key, conns)
        if not b.is_io:
            raise self.fail(key, 'must be an I/O address "CONNECTION:ADDRESS"')
        if b.connection != mv.connection:
            raise self.fail(key, f"must be on the connection of mv ({mv.connection!r}): {why}")
        return b

    def output_tags(
        self,
        raw: Mapping[str, Any],
        key: str,
        tags: tuple[str, ...],
        conns: Mapping[str, ConnectionConfig],
        mv: Binding,
    ) -> dict[str, Binding]:
        """The structure's optional output tags (``open``, ``close``), on the MV's connection."""
        out: dict[str, Binding] = {}
        for tag in tags:
            if tag not in raw:
                continue
            why = "the outputs are written with the MV in one batched request"
            b = self.written_with_mv(raw[tag], f"{key}.{tag}", conns, mv, why)
            taken = [n for n, o in (("mv", mv), *out.items()) if o.address == b.address]
            if taken:
                raise self.fail(f"{key}.{tag}", f"is the address of {taken[0]} ({b})")
            out[tag] = b
        return out

    def alarm_outputs(
        self,
        raw: Mapping[str, Any],
        key: str,
        conns: Mapping[str, ConnectionConfig],
        mv: Binding,
        health: Mapping[str, Any],
        taken: Mapping[str, Binding | None],
    ) -> dict[str, Binding]:
        """``alarm_outputs``: the alarms' states written with the MV (runtime.health)."""
        table = raw.get("alarm_outputs")
        if table is None:
            return {}
        if not isinstance(table, Mapping):
            raise self.fail(f"{key}.alarm_outputs", 'must be a table such as { h_state = "..." }')
        if not table:
            raise self.fail(f"{key}.alarm_outputs", "is empty: bind at least one alarm output")
        used = {n: b for n, b in taken.items() if b is not None and b.is_io}
        out: dict[str, Binding] = {}
        for tag, value in table.items():
            k = f"{key}.alarm_outputs.{tag}"
            why = alarm_output_problem(tag, health)
            if why:
                raise self.fail(k, why)
            b = self.written_with_mv(
                value,
                k,
                conns,
                mv,
                "the alarm outputs are written with the MV in one batched request",
            )
            why = PROTOCOLS[conns[b.connection].protocol].writable_problem(b.address)  # type: ignore[index]
            if why:
                raise self.fail(k, why)
            same = [n for n, o in (*used.items(), *out.items()) if o.address == b.address]
            if same:
                raise self.fail(k, f"is the address of {same[0]} ({b})")
            out[tag] = b
        return out

    def mv_tables(
        self, raw: Mapping[str, Any], key: str, structure: str
    ) -> list[tuple[str, dict[str, Any]]]:
        """``(key path, table)`` of the blocks whose output is (or is selected as) the MV."""
        st = _STRUCTURES[structure]
        example = '{ type = "PID", kp = 1.0 }'
        role = "block" if st.lone_block else st.mv_roles[0]
        if role in st.array_roles:
            lst = raw.get(role)
            if not isinstance(lst, list) or len(lst) < 2:
                raise self.fail(
                    f"{key}.{role}", "must be an array of at least two controller tables"
                )
            roles = [(f"{role}[{j}]", b) for j, b in enumerate(lst)]
            example = '{ type = "PID", kp = 1.0, measure = "y" }'
        else:
            roles = [(role, raw.get(role))]
        out = []
        for role, t in roles:
            if not isinstance(t, dict):
                raise self.fail(f"{key}.{role}", f"missing: a table such as {example}")
            out.append((f"{key}.{role}", t))
        return out

    def structure_entry(
        self,
        raw: Mapping[str, Any],
        key: str,
        structure: str,
        ts: float,
        name: str,
        patched: Mapping[str, dict[str, Any]],
    ) -> ControllerSpec:
        """The structure's blocks, checked by the simulator's parser (one controller entry)."""
        entry: dict[str, Any] = {"name": name}
        for k in STRUCTURES[structure]:
            if k in raw:
                entry[k] = raw[k]
        role = _STRUCTURES[structure].mv_roles[0]  # the MV's blocks, as patched
        if role in _STRUCTURES[structure].array_roles:
            entry[role] = [patched[f"{key}.{role}[{j}]"] for j in range(len(raw[role]))]
        else:
            entry[role] = patched[f"{key}.{role}"]
        for k, v in entry.items():
            if isinstance(v, dict) and "ts" in v:
                raise self.fail(f"{key}.{k}.ts", "set the sample time once, as the loop's ts")
        return parse_controller(
            entry, structure, ts, key=key, file=self.file, error=RuntimeConfigError
        )

    def fault_action(self, raw: Mapping[str, Any], key: str) -> dict[str, Any]:
        """``on_fault`` (``"safe_value"`` or ``"hold"``) and ``hold_time`` [s] of a loop."""
        on_fault = self.choice(
            raw, "on_fault", f"{key}.on_fault", ("safe_value", "hold"), "safe_value"
        )
        hold = self.number(raw, "hold_time", f"{key}.hold_time", 0.0)
        if not (math.isfinite(hold) and hold >= 0):
            raise self.fail(f"{key}.hold_time", f"must be a finite number >= 0, got {hold!r}")
        if "hold_time" in raw and on_fault != "hold":
            raise self.fail(f"{key}.hold_time", 'only with on_fault = "hold"')
        if on_fault == "hold" and "hold_time" not in raw:
            raise self.fail(
                f"{key}.hold_time", 'missing: on_fault = "hold" needs how long to hold [s]'
            )
        return {"on_fault": on_fault, "hold_time": hold}

    def time_settings(self, raw: Mapping[str, Any], key: str, ts: float) -> dict[str, Any]:
        """``on_late``, ``max_dt`` [s], ``initial_mv`` and ``start`` of a loop (docs/runtime.md)."""
        on_late = self.choice(raw, "on_late", f"{key}.on_late", ("hold", "last_good"), "hold")
        max_dt = self.number(raw, "max_dt", f"{key}.max_dt", None, positive=True)
        if max_dt is not None and not ts <= max_dt <= MAX_DT_TS * ts * (1 + 1e-12):
            raise self.fail(
                f"{key}.max_dt",
                f"must lie between ts and {MAX_DT_TS:g} ts ({ts!r} .. {MAX_DT_TS * ts:g} s): the "
                f"blocks are proven stable for dt up to {MAX_DT_TS:g} ts, got {max_dt!r}",
            )
        initial = self.number(raw, "initial_mv", f"{key}.initial_mv", None)
        if initial is not None and not math.isfinite(initial):
            raise self.fail(f"{key}.initial_mv", "must be finite")
        start = self.choice(raw, "start", f"{key}.start", ("read_back", "block"), "read_back")
        return {"on_late": on_late, "max_dt": max_dt, "initial_mv": initial, "start": start}
