"""``ctrlblocks export``: tuned blocks as PLC code.

::

    ctrlblocks export pid --set kp=2 --set ti=30 --set ts=0.1 --target codesys --out PID.st
    ctrlblocks tune pid ... --json > pid.json
    ctrlblocks export --from-json pid.json --target tia --out PID.scl
    ctrlblocks export --from-json pid.json --from-json adrc.json --target plcopen --out lib.xml
    ctrlblocks export --toml loop.toml --controller "PID (AMIGO)" --target beremiz --out pid.xml
    ctrlblocks export adrc --from-json adrc.json --target twincat --tcpou --test --out plc_dir/

Parameters are the block's configuration fields (see the blocks' docs);
``--from-json`` takes the fields it knows from a ``tune --json`` output,
including the sample time the tuning was made for (a ``--set ts`` that differs
is refused: the tuning would not hold), and ``--set`` overrides the others.
Several ``--from-json`` files (or ``--toml --all``) export into one project
whose helper POUs are written once.  ``--toml`` reads a scenario or runtime
TOML file and exports a controller of it (``--controller`` names a
``[[controllers]]`` entry or a ``[[loops]]`` loop; ``--role`` a block of the
entry); a runtime loop's ``unit`` table names the units in the comments
(else ``--unit pv=bar --unit mv=%``).  ``--test`` adds the test bench: a
recorded trace and the outputs the PLC must show (docs/plc.md).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import click

from .export import TARGETS
from .specs import EXPORTED

__all__ = ["export_command"]

_TYPES = {"pid": "PID", "adrc": "ADRC", "leadlag": "LeadLag"}
_COVERED = ", ".join(EXPORTED)


def _value(text: str) -> Any:
    """A ``--set`` value: JSON (numbers, true/false, "strings"), +-inf/nan, else the text."""
    low = text.strip().lower()
    if low in ("inf", "+inf", "-inf", "nan"):
        return float(low)
    try:
        return json.loads(text)
    except ValueError:
        return text


def _sets(pairs: tuple[str, ...]) -> dict[str, Any]:
    out = {}
    for pair in pairs:
        key, sep, val = pair.partition("=")
        if not sep or not key.strip():
            raise click.UsageError(f"--set needs KEY=VALUE, got {pair!r}")
        out[key.strip()] = _value(val)
    return out


def _from_json(path: str, kind: str | None) -> tuple[str, dict[str, Any]]:
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise click.ClickException(f"{path}: cannot read JSON ({exc})") from None
    if not isinstance(data, dict):
        raise click.ClickException(f"{path}: expected a JSON object (a tune --json output)")
    if kind is None:
        kind = "adrc" if "omega_c" in data else "pid" if "kp" in data else None
        if kind is None:
            raise click.UsageError(f"{path}: give the block type (pid, adrc or leadlag)")
    return kind, data


def _tuned_ts(path: str, data: dict[str, Any], sets: dict[str, Any]) -> dict[str, Any]:
    """The sample time of a tuning file: ``ts`` (tune adrc) or ``margins_ts`` (tune pid, the
    sample time its margins hold for); a different ``--set ts`` is refused."""
    tuned = data.get("ts", data.get("margins_ts"))
    if tuned is None:
        if "ts" not in sets:
            raise click.UsageError(f"{path} does not say which sample time the tuning is for: "
                                   "give --set ts=SECONDS")  # fmt: skip
        return {}
    if not isinstance(tuned, int | float) or isinstance(tuned, bool):
        raise click.ClickException(f"{path}: ts must be a number, got {tuned!r}")
    if "ts" in sets and sets["ts"] != tuned:
        raise click.UsageError(
            f"{path}: the tuning was made for ts = {tuned} s; --set ts={sets['ts']} would run it "
            f"at another sample time (re-tune with --ts {sets['ts']}, or leave --set ts out)")
    return {"ts": float(tuned)}


def _config_fields(kind: str) -> set[str]:
    from .. import blocks

    cls = getattr(blocks, _TYPES[kind])
    return {f.name for f in dataclasses.fields(cls.Config)}


def _from_toml(
    path: str, controller: str | None, role: str | None, every: bool
) -> tuple[list[Any], dict[str, str]]:
    """The block(s) of a TOML file and the loop's units (``every``: all of them)."""
    from ..loops.spec import build
    from ..loops.toml import KeyPathError, read_toml
    from ..sim.scenario import load_scenario

    units: dict[str, dict[str, str]] = {}
    try:
        text = Path(path).read_text(encoding="utf-8")
        doc = read_toml(text, path)
        if "scenario" in doc:
            sc = load_scenario(path)
            entries = {c.name: (c.blocks, sc.ts) for c in sc.controllers}
        else:
            from ..runtime.config import load_config

            cfg = load_config(path)
            entries = {lc.name: (lc.spec().blocks, lc.ts) for lc in cfg.loops}
            units = {lc.name: dict(lc.units) for lc in cfg.loops}
    except OSError as exc:
        raise click.ClickException(f"{path}: cannot read the file ({exc.strerror})") from None
    except KeyPathError as exc:
        raise click.ClickException(str(exc)) from None
    if not entries:
        raise click.ClickException(f"{path}: no [[controllers]] or [[loops]] entry")
    if every:
        if controller is not None or role is not None:
            raise click.UsageError("--all exports every block: no --controller or --role with it")
        chosen = [(n, r) for n, (specs, _ts) in entries.items() for r, s in specs.items()
                  if getattr(s, "type", None) in EXPORTED]  # fmt: skip
        if not chosen:
            raise click.ClickException(f"{path}: no block the export covers ({_COVERED})")
    else:
        name = controller if controller is not None else next(iter(entries))
        if name not in entries:
            raise click.UsageError(
                f"{path}: no controller {name!r}; entries: {', '.join(entries)}")
        specs = entries[name][0]
        roles = [r for r, s in specs.items() if getattr(s, "type", None) in EXPORTED]
        if role is None:
            if not roles:
                raise click.ClickException(
                    f"{path}: {name!r} has no block the export covers ({_COVERED})")
            role = roles[0]
        if role not in roles:
            raise click.UsageError(f"{name!r} has no exportable block {role!r}: {', '.join(roles)}")
        chosen = [(name, role)]
    try:
        blocks = [build(entries[n][0][r], entries[n][1], kind="block", file=path)
                  for n, r in chosen]  # fmt: skip
    except KeyPathError as exc:
        raise click.ClickException(str(exc)) from None
    return blocks, units.get(chosen[0][0], {}) if len(chosen) == 1 else {}


def _units(pairs: tuple[str, ...]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        key, sep, val = pair.partition("=")
        if not sep or key.strip() not in ("pv", "sp", "mv"):
            raise click.UsageError(f"--unit needs pv=UNIT, sp=UNIT or mv=UNIT, got {pair!r}")
        out[key.strip()] = val.strip()
    return out


@click.command("export")
@click.argument("block_type", required=False, type=click.Choice(sorted(_TYPES)))
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="A configuration field.")
@click.option("--from-json", "from_json", multiple=True, type=click.Path(dir_okay=False),
              help="A tune --json output (repeat: several blocks in one project).")
@click.option("--toml", type=click.Path(dir_okay=False), help="A scenario or runtime TOML file.")
@click.option("--controller", help="The [[controllers]] entry or [[loops]] loop of --toml.")
@click.option("--role", help="The block of that entry (default: its first exportable block).")
@click.option("--all", "every", is_flag=True, help="--toml: every exportable block, one project.")
@click.option("--target", type=click.Choice(TARGETS), default="codesys", show_default=True)
@click.option("--name", help="The FUNCTION_BLOCK's name (default CB_PID, CB_ADRC, CB_LEADLAG).")
@click.option("--unit", "unit_pairs", multiple=True, metavar="SIGNAL=UNIT",
              help="pv=..., mv=...: the units named in the comments.")
@click.option("--test", "test", is_flag=True,
              help="Add the test bench (TcUnit for twincat, CfUnit for codesys, else plain).")
@click.option("--test-framework", type=click.Choice(["plain", "tcunit", "cfunit"]),
              help="The test bench's form (implies --test).")
@click.option("--tcpou", is_flag=True, help="twincat: one .TcPOU file per POU into --out (a dir).")
@click.option("--out", type=click.Path(), help="Output file (directory with --tcpou); stdout.")
def export_command(
    block_type: str | None,
    sets: tuple[str, ...],
    from_json: tuple[str, ...],
    toml: str | None,
    controller: str | None,
    role: str | None,
    every: bool,
    target: str,
    name: str | None,
    unit_pairs: tuple[str, ...],
    test: bool,
    test_framework: str | None,
    tcpou: bool,
    out: str | None,
) -> None:
    """Export a tuned PID, ADRC or LeadLag as PLC code (IEC 61131-3 ST, TIA SCL, PLCopen XML).

    The code is translated from the block's own per-cycle Python and computes
    what the block computes with precision="float32" (docs/plc.md).
    """
    from .. import blocks
    from ..blocks import ParameterError
    from . import UnsupportedBlock, export, export_files

    params = _sets(sets)
    units = _units(unit_pairs)
    if toml is not None:
        if block_type or from_json:
            raise click.UsageError("--toml gives the block: no BLOCK_TYPE or --from-json with it")
        made, loop_units = _from_toml(toml, controller, role, every)
        units = {**loop_units, **units}
        for block in made:
            if params:
                try:
                    block.configure(**params)
                except (ParameterError, TypeError) as exc:
                    raise click.ClickException(f"--set: {exc}") from None
    else:
        if every:
            raise click.UsageError("--all goes with --toml")
        sources: list[tuple[str | None, str | None]] = [(block_type, f) for f in from_json]
        if not sources:
            if block_type is None:
                raise click.UsageError(
                    "give BLOCK_TYPE (pid, adrc, leadlag), --from-json or --toml")
            sources = [(block_type, None)]
        made = []
        for kind, path in sources:
            base: dict[str, Any] = {}
            if path is not None:
                kind, data = _from_json(path, kind)
                fields = _config_fields(kind)
                base = {k: v for k, v in data.items() if k in fields}
                base.update(_tuned_ts(path, data, params))
                if isinstance(base.get("form"), str):
                    base["form"] = base["form"].lower()  # tune prints "ISA"
            assert kind is not None
            cfg = {**base, **params}
            unknown = sorted(set(cfg) - _config_fields(kind))
            if unknown:
                raise click.UsageError(f"{_TYPES[kind]} has no parameter(s) {', '.join(unknown)}")
            try:
                made.append(getattr(blocks, _TYPES[kind])(**cfg))
            except ParameterError as exc:
                raise click.ClickException(f"{path or kind}: {exc}") from None
    if name is not None and len(made) != 1:
        raise click.UsageError("--name names one block; several are exported")
    chosen: Any = {name: made[0]} if name is not None else made if len(made) > 1 else made[0]
    with_test: bool | str = test_framework or test
    try:
        if tcpou:
            if target != "twincat" or out is None:
                raise click.UsageError("--tcpou needs --target twincat and --out DIRECTORY")
            files = export_files(chosen, "twincat", units=units, test=with_test)
        else:
            text = export(chosen, target, units=units, test=with_test)
    except (UnsupportedBlock, ValueError) as exc:
        raise click.ClickException(str(exc)) from None
    if tcpou:
        assert out is not None
        d = Path(out)
        try:
            d.mkdir(parents=True, exist_ok=True)
            for fname, content in files.items():
                (d / fname).write_text(content, encoding="utf-8")
        except OSError as exc:
            raise click.ClickException(f"{out}: cannot write ({exc.strerror})") from None
        click.echo(f"wrote {len(files)} .TcPOU files to {d}", err=True)
        return
    if out is None:
        click.echo(text, nl=False)
        return
    try:
        Path(out).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise click.ClickException(f"{out}: cannot write ({exc.strerror})") from None
    click.echo(f"wrote {out} ({target})", err=True)
