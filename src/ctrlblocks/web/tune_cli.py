"""``ctrlblocks tune-live``: live auto-tuning of a loop of a running ``ctrlblocks serve``.

::

    ctrlblocks tune-live --loop p3 --method step --amplitude 0.5 --pv-max 2.5 --user eng
    ctrlblocks tune-live --loop p3 --status
    ctrlblocks tune-live --loop p3 --accept PID_AMIGO      # or --reject
    ctrlblocks tune-live --loop p3 --abort

It talks to the faceplate's API (``/api/loops/NAME/tune``, docs/faceplate.md)
with an engineer's login, so the role check, the engineering ranges and the
audit trail are the page's.  Starting waits for the end of the test and
prints its progress (a line every few seconds, on a terminal or not), then
the identified model and the proposals with their margins; on a terminal it
asks which proposal to accept.  Ctrl-C while waiting aborts the test.  The
password comes from ``--password-env VAR`` or a prompt.
"""

from __future__ import annotations

import json
import os
import sys
import time
from typing import Any

import click

__all__ = ["tune_live"]

POLL = 0.5
"""Seconds between two status requests while a test runs."""

PROGRESS_EVERY = 5.0
"""Seconds between two progress lines."""


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return f"{x:.4g}"
    return "-" if x is None else str(x)


def describe(st: dict[str, Any]) -> list[str]:
    """The result of a test as text lines: state, model, proposals with margins, warnings."""
    lines = [f"{st['method']} test: {st['state']}" + (f" ({st['reason']})" if st["reason"] else "")]
    model = st.get("model")
    if model:
        if model.get("kind") == "FOPDT":
            lines.append(
                f"  model: FOPDT gain {_fmt(model['gain'])}, time constant "
                f"{_fmt(model['time_constant'])} s, dead time {_fmt(model['dead_time'])} s"
            )
        else:
            lines.append(
                f"  ultimate point: ku {_fmt(model['ku'])}, pu {_fmt(model['pu'])} s"
            )
    margins = st.get("margins") or {}
    for name, prop in (st.get("proposals") or {}).items():
        params = ", ".join(f"{k} {_fmt(v)}" for k, v in prop.items() if k not in ("type",))
        lines.append(f"  {name:<10} {prop.get('type', '')}: {params}")
        mg = margins.get(name)
        if mg:
            lines.append(f"  {'':<10} {mg.get('summary') or mg.get('error')}")
    if st.get("proposals") and not margins and model and model.get("kind") != "FOPDT":
        lines.append("  (no margins: a relay test gives no model; a step test does)")
    for w in st.get("warnings") or []:
        lines.append(f"  warning: {w}")
    if st["state"] in ("accepted", "rejected"):
        what = f": {st['accepted']}" if st["accepted"] else ""
        lines.append(f"  {st['state']} by {st.get('decided_by', '')}{what}")
    return lines


def _progress(st: dict[str, Any], loop: dict[str, Any] | None) -> str:
    pv = "" if loop is None else f", PV {_fmt(loop.get('pv'))}"
    return (
        f"{st['method']} test running: {st['elapsed']:.1f} s (at most {st['max_time']:g} s), "
        f"MV {_fmt(st.get('mv'))}{pv}"
    )


@click.command("tune-live")
@click.option("--loop", "loop", required=True, help="The loop to tune.")
@click.option("--method", type=click.Choice(["step", "relay"]), default=None,
              help="Start a test: step (pretuning) or relay (fine tuning).")  # fmt: skip
@click.option("--amplitude", type=float, default=None,
              help="Step size (signed) or relay amplitude [MV unit].")  # fmt: skip
@click.option("--mv-min", type=float, default=None, help="Lowest MV of the test [MV unit].")
@click.option("--mv-max", type=float, default=None, help="Highest MV of the test [MV unit].")
@click.option("--pv-min", type=float, default=None, help="The test aborts below this PV.")
@click.option("--pv-max", type=float, default=None, help="The test aborts above this PV.")
@click.option("--max-time", type=float, default=None, help="Longest test [s] (default 3600).")
@click.option("--hysteresis", type=float, default=None, help="Relay hysteresis [PV unit].")
@click.option("--pre-time", type=float, default=None, help="Step: hold time before it [s].")
@click.option("--status", "show_status", is_flag=True, help="Show the loop's test and exit.")
@click.option("--abort", "do_abort", is_flag=True, help="Abort the running test.")
@click.option("--accept", "accept", default=None, metavar="PROPOSAL",
              help="Apply this proposal of the finished test.")  # fmt: skip
@click.option("--force", is_flag=True, help="With --accept: also a proposal called fragile.")
@click.option("--reject", "do_reject", is_flag=True, help="Reject the finished test's result.")
@click.option("--no-wait", is_flag=True, help="Start the test and return at once.")
@click.option("--json", "as_json", is_flag=True, help="Print the final status as JSON.")
@click.option("--url", envvar="CTRLBLOCKS_URL", default="http://127.0.0.1:8000/",
              show_default=True,
              help="The faceplate of the running runtime; also $CTRLBLOCKS_URL.")  # fmt: skip
@click.option("--user", envvar="CTRLBLOCKS_USER", default=None,
              help="Engineer to log in as; also $CTRLBLOCKS_USER (else asked).")  # fmt: skip
@click.option("--password-env", default=None,
              help="Read the password from this environment variable (else asked).")  # fmt: skip
@click.option("--cafile", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Certificate (PEM) that signs the faceplate's HTTPS certificate.")  # fmt: skip
def tune_live(
    loop: str,
    method: str | None,
    amplitude: float | None,
    mv_min: float | None,
    mv_max: float | None,
    pv_min: float | None,
    pv_max: float | None,
    max_time: float | None,
    hysteresis: float | None,
    pre_time: float | None,
    show_status: bool,
    do_abort: bool,
    accept: str | None,
    force: bool,
    do_reject: bool,
    no_wait: bool,
    as_json: bool,
    url: str,
    user: str | None,
    password_env: str | None,
    cafile: str | None,
) -> None:
    """Auto-tune a loop of a running 'ctrlblocks serve' live: a step or relay test, then accept.

    Start a test with --method and --amplitude (the MV bounds default to the
    loop's limits; --pv-min/--pv-max abort it); it waits, shows the progress,
    the identified model and the proposed tunings with their margins, and on
    a terminal asks which to accept.  Nothing is applied without --accept (or
    that answer).  Needs an engineer's login on the faceplate at --url.
    """
    from .client import FaceplateClient, FaceplateError

    actions = [bool(method), show_status, do_abort, accept is not None, do_reject]
    if sum(actions) != 1:
        raise click.UsageError(
            "give exactly one of --method (start a test), --status, --abort, --accept, --reject"
        )
    if method and amplitude is None:
        raise click.UsageError("--method needs --amplitude (step size or relay amplitude)")
    base = f"/api/loops/{_quote(loop)}/tune"
    try:
        client = FaceplateClient(url, cafile=cafile)
        if not show_status:
            _login(client, user, password_env)
        if show_status:
            try:
                st = client.get(base)
            except FaceplateError as exc:
                if exc.status != 401:  # a private faceplate: log in to watch
                    raise
                _login(client, user, password_env, role=None)
                st = client.get(base)
        elif do_abort:
            st = client.post(f"{base}/abort", {"reason": "from the command line"})["tuning"]
        elif do_reject:
            st = client.post(f"{base}/reject")["tuning"]
        elif accept is not None:
            st = client.post(f"{base}/accept", {"proposal": accept, "force": force})["tuning"]
        else:
            body = {"method": method, "amplitude": amplitude, "mv_min": mv_min, "mv_max": mv_max,
                    "pv_min": pv_min, "pv_max": pv_max, "max_time": max_time,
                    "hysteresis": hysteresis, "pre_time": pre_time}  # fmt: skip
            body = {k: v for k, v in body.items() if v is not None}
            st = client.post(base, body)["tuning"]
            click.echo(f"{method} test started on {loop} (MV {_fmt(st['u0'])} before it)")
            if not no_wait:
                st = _wait(client, loop, base)
                st = _decide(client, loop, base, st, as_json)
    except FaceplateError as exc:
        where = f"{exc.field}: " if exc.field and exc.field not in ("login", "tune") else ""
        raise click.ClickException(f"{where}{exc.message}") from None
    if st is None:
        click.echo(f"no live tuning on {loop} yet")
        return
    if as_json:
        click.echo(json.dumps(st, indent=2))
    else:
        for line in describe(st):
            click.echo(line)
    if st["state"] == "done":
        click.echo(
            f"nothing applied: accept with 'ctrlblocks tune-live --loop {loop} --accept NAME' "
            "(or --reject)",
            err=True,
        )
    if st["state"] in ("aborted", "failed"):
        sys.exit(1)


def _quote(name: str) -> str:
    import urllib.parse

    return urllib.parse.quote(name, safe="")


def _login(
    client: Any, user: str | None, password_env: str | None, role: str | None = "engineer"
) -> None:
    if user is None:
        user = click.prompt("user")
    if password_env is not None:
        password = os.environ.get(password_env)
        if password is None:
            raise click.ClickException(f"environment variable {password_env} is not set")
    else:
        password = click.prompt(f"password of {user}", hide_input=True)
    got = client.login(user, password)
    if role is not None and got != role:
        raise click.ClickException(f"{user} is a {got}: live tuning needs an {role}")


def _wait(client: Any, loop: str, base: str) -> dict[str, Any]:
    """Poll until the test has ended (and its margins are computed); Ctrl-C aborts it."""
    last = time.monotonic()
    try:
        while True:
            st = client.get(base)
            if st["state"] != "running" and (st["state"] != "done" or st["margins_ready"]):
                return st  # type: ignore[no-any-return]
            if time.monotonic() - last >= PROGRESS_EVERY:
                last = time.monotonic()
                click.echo(_progress(st, client.get(f"/api/loops/{_quote(loop)}")))
            time.sleep(POLL)
    except KeyboardInterrupt:
        click.echo("interrupted: aborting the test", err=True)
        ans = client.post(f"{base}/abort", {"reason": "interrupted on the command line"})
        return ans["tuning"]  # type: ignore[no-any-return]


def _decide(client: Any, loop: str, base: str, st: dict[str, Any], as_json: bool) -> Any:
    """On a terminal: ask which proposal to accept; otherwise say how to decide later."""
    if st["state"] != "done":
        return st
    if as_json or not (sys.stdin.isatty() and sys.stdout.isatty()):
        return st  # the caller says how to decide
    for line in describe(st):
        click.echo(line)
    names = list(st["proposals"])
    choice = click.prompt(
        f"accept which proposal ({', '.join(names)}), 'reject', or Enter to decide later",
        default="",
        show_default=False,
    ).strip()
    if not choice:
        return st
    if choice == "reject":
        return client.post(f"{base}/reject")["tuning"]
    return client.post(f"{base}/accept", {"proposal": choice})["tuning"]
