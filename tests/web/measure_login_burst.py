"""Measure what a burst of concurrent wrong logins does to the control cycle (not a test).

Serves the demo of ``ctrlblocks serve`` (the 50 ms PI flow loop, the 100 ms
ADRC pressure loop) on 127.0.0.1 with an operator at the real scrypt cost
(n = 2**14), then counts the flow loop's cycle overruns (period above
1.5 ts) and its longest period in two windows of the same length: one quiet,
one in which ``--logins`` wrong logins of the operator are sent at once::

    .venv/bin/python -m tests.web.measure_login_burst --logins 40 --window 6.5

Prints one line per window and the answers the logins got.  Run it against
another source tree with ``PYTHONPATH=OTHER/src`` to compare.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import json
import logging
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ctrlblocks.web import UserStore
from ctrlblocks.web.demo import demo_runtime

from .conftest import running_server

log = logging.getLogger("measure_login_burst")


def flow_period(runtime: Any) -> tuple[int, float]:
    """Overruns so far and the longest period [s] of the flow loop."""
    p = runtime.state("flow")["period"]
    return int(p["overruns"]), float(p["max"])


async def burst(url: str, n: int) -> collections.Counter[int]:
    """Send ``n`` wrong logins at once; count the answers by status."""
    import httpx2 as httpx

    async with httpx.AsyncClient(base_url=url, timeout=120) as c:
        body = {"user": "operator1", "password": "not the password"}
        rs = await asyncio.gather(*(c.post("api/login", json=body) for _ in range(n)))
    return collections.Counter(r.status_code for r in rs)


def burst_from_another_process(url: str, n: int) -> dict[int, int]:
    """:func:`burst` in a child process (its client must not share the server's GIL)."""
    code = (
        "import asyncio, json, sys; from tests.web.measure_login_burst import burst; "
        "print(json.dumps(asyncio.run(burst(sys.argv[1], int(sys.argv[2])))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, url, str(n)], capture_output=True, text=True, check=True
    )
    return {int(k): v for k, v in json.loads(out.stdout).items()}


def window(runtime: Any, seconds: float, action: Any = None) -> tuple[int, Any]:
    """Overruns of the flow loop during ``seconds`` [s] (running ``action`` at its start)."""
    before, _ = flow_period(runtime)
    t0 = time.monotonic()
    result = action() if action is not None else None
    time.sleep(max(0.0, seconds - (time.monotonic() - t0)))
    after, _ = flow_period(runtime)
    return after - before, result


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logins", type=int, default=40, help="wrong logins sent at once")
    ap.add_argument("--window", type=float, default=6.5, help="length of each window [s]")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stdout)
    logging.getLogger("httpx2").setLevel(logging.WARNING)
    with tempfile.TemporaryDirectory() as tmp:
        runtime, _ = demo_runtime(Path(tmp) / "history.sqlite")
        users = UserStore(Path(tmp) / "users.json")
        users.add("operator1", "the real password")  # the real cost: n = 2**14
        with running_server(runtime, users) as url:
            log.info("warming up 3 s ...")
            time.sleep(3.0)
            quiet, _ = window(runtime, args.window)
            log.info("quiet window %.1f s: %d overruns of the 50 ms loop", args.window, quiet)

            def timed_burst() -> tuple[float, Any]:
                t0 = time.monotonic()
                codes = burst_from_another_process(url, args.logins)
                return time.monotonic() - t0, codes

            n, (took, codes) = window(runtime, args.window, timed_burst)
            log.info(
                "burst window %.1f s (%d wrong logins answered in %.2f s: %s): %d overruns",
                max(args.window, took),
                args.logins,
                took,
                dict(sorted(codes.items())),
                n,
            )
            log.info("longest period of the 50 ms loop: %.3f s", flow_period(runtime)[1])


if __name__ == "__main__":
    main()
