"""``ctrlblocks export``: a tuned block as PLC code.

::

    ctrlblocks export pid --set kp=2 --set ti=30 --set ts=0.1 --target codesys --out PID.st
    ctrlblocks tune pid ... --json > pid.json
    ctrlblocks export pid --from-json pid.json --set ts=0.1 --target tia --out PID.scl
    ctrlblocks export --toml loop.toml --controller "PID (AMIGO)" --target plcopen --out pid.xml
    ctrlblocks export adrc --from-json adrc.json --target twincat --tcpou --out plc_dir/

Parameters are the block's configuration fields (see the blocks' docs);
``--from-json`` takes the fields it knows from a ``tune --json`` output and
``--set`` overrides.  ``--toml`` reads a scenario or runtime TOML file and
exports a controller of it (``--controller`` names a ``[[controllers]]``
entry or a ``[[loops]]`` loop; ``--role`` a block of the entry).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import click

from .export import TARGETS

__all__ = ["export_command"]

_TYPES = {"pid": "PID", "adrc": "ADRC", "leadlag": "LeadLag"}


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


def _config_fields(kind: str) -> set[str]:
    from .. import blocks

    cls = getattr(blocks, _TYPES[kind])
    return {f.name for f in dataclasses.fields(cls.Config)}


def _from_toml(path: str, controller: str | None, role: str | None) -> Any:
    from ..loops.spec import build
    from ..loops.toml import KeyPathError, read_toml
    from ..sim.scenario import load_scenario

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
    except OSError as exc:
        raise click.ClickException(f"{path}: cannot read the file ({exc.strerror})") from None
    except KeyPathError as exc:
        raise click.ClickException(str(exc)) from None
    if not entries:
        raise click.ClickException(f"{path}: no [[controllers]] or [[loops]] entry")
    name = controller if controller is not None else next(iter(entries))
    if name not in entries:
        raise click.UsageError(f"{path}: no controller {name!r}; entries: {', '.join(entries)}")
    specs, ts = entries[name]
    roles = {r: s for r, s in specs.items() if getattr(s, "type", None) in _TYPES.values()}
    if role is None:
        if not roles:
            raise click.ClickException(f"{path}: {name!r} has no PID, ADRC or LeadLag block")
        role = next(iter(roles))
    if role not in roles:
        raise click.UsageError(f"{name!r} has no exportable block {role!r}: {', '.join(roles)}")
    try:
        return build(roles[role], ts, kind="block", file=path)
    except KeyPathError as exc:
        raise click.ClickException(str(exc)) from None


@click.command("export")
@click.argument("block_type", required=False, type=click.Choice(sorted(_TYPES)))
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help="A configuration field.")
@click.option("--from-json", type=click.Path(dir_okay=False), help="A tune --json output.")
@click.option("--toml", type=click.Path(dir_okay=False), help="A scenario or runtime TOML file.")
@click.option("--controller", help="The [[controllers]] entry or [[loops]] loop of --toml.")
@click.option("--role", help="The block of that entry (default: its first PID/ADRC/LeadLag).")
@click.option("--target", type=click.Choice(TARGETS), default="codesys", show_default=True)
@click.option("--tcpou", is_flag=True, help="twincat: one .TcPOU file per POU into --out (a dir).")
@click.option("--out", type=click.Path(), help="Output file (directory with --tcpou); stdout.")
def export_command(
    block_type: str | None,
    sets: tuple[str, ...],
    from_json: str | None,
    toml: str | None,
    controller: str | None,
    role: str | None,
    target: str,
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
    if toml is not None:
        if block_type or from_json:
            raise click.UsageError("--toml gives the block: no BLOCK_TYPE or --from-json with it")
        block = _from_toml(toml, controller, role)
        if params:
            try:
                block.configure(**params)
            except (ParameterError, TypeError) as exc:
                raise click.ClickException(f"--set: {exc}") from None
    else:
        kind = block_type
        base: dict[str, Any] = {}
        if from_json is not None:
            kind, data = _from_json(from_json, kind)
            fields = _config_fields(kind)
            base = {k: v for k, v in data.items() if k in fields}
            if isinstance(base.get("form"), str):
                base["form"] = base["form"].lower()  # tune prints "ISA"
        if kind is None:
            raise click.UsageError("give BLOCK_TYPE (pid, adrc, leadlag), --from-json or --toml")
        cfg = {**base, **params}
        unknown = sorted(set(cfg) - _config_fields(kind))
        if unknown:
            raise click.UsageError(f"{_TYPES[kind]} has no parameter(s) {', '.join(unknown)}")
        try:
            block = getattr(blocks, _TYPES[kind])(**cfg)
        except ParameterError as exc:
            raise click.ClickException(str(exc)) from None
    try:
        if tcpou:
            if target != "twincat" or out is None:
                raise click.UsageError("--tcpou needs --target twincat and --out DIRECTORY")
            files = export_files(block, "twincat")
        else:
            text = export(block, target)
    except UnsupportedBlock as exc:
        raise click.ClickException(str(exc)) from None
    if tcpou:
        assert out is not None
        d = Path(out)
        try:
            d.mkdir(parents=True, exist_ok=True)
            for name, content in files.items():
                (d / name).write_text(content, encoding="utf-8")
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
