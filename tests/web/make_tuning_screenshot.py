"""Take the figure of docs/autotuning.md: a live step test from the faceplate's tuning panel.

Run from the repository root (about 90 s of real time)::

    .venv/bin/python -m tests.web.make_tuning_screenshot docs/figures/faceplate_tuning.png

It serves the demo of ``ctrlblocks serve`` (the simulated three-tank loop
``pressure``, ADRC, p3 and the supply pressure in bar) on 127.0.0.1, logs in
as a temporary engineer, puts the loop in MAN, runs a step test of +0.5 bar
from the *Live tuning* panel (abort above 2.5 bar, at most 80 s), waits for the model and
the proposals with their margins and saves the faceplate.  Not a test
(pytest does not collect it).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from ctrlblocks.web import UserStore
from ctrlblocks.web.demo import demo_runtime

from .conftest import chromium_context, running_server


def main(out: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        runtime, _ = demo_runtime(Path(tmp) / "history.sqlite")
        users = UserStore(Path(tmp) / "users.json")
        users.add("engineer1", "demo password", role="engineer", n=2**10)
        with running_server(runtime, users) as url, chromium_context((1400, 1500)) as browser:
            page = browser.new_page()
            page.set_default_timeout(180_000)
            page.goto(url + "#pressure")
            page.wait_for_function("() => window.faceplate && window.faceplate.updates > 5")
            page.fill("#login-user", "engineer1")
            page.fill("#login-password", "demo password")
            page.click("#btn-login")
            page.wait_for_function("() => window.faceplate.user === 'engineer1'")
            page.click("#btn-man")
            page.wait_for_timeout(5000)  # a steady MV before the step
            page.click("#tune-box summary")
            page.fill("#tune-amplitude", "0.5")
            page.fill("#tune-pv-max", "2.5")
            page.fill("#tune-max-time", "80")  # the 1 mbar noise keeps it from "settled"
            page.click("#tune-start")
            page.wait_for_function(
                "() => document.querySelector('#tune-status').textContent === 'step test done'"
                " && !document.querySelector('#tune-proposals').textContent.includes('computing')"
            )
            page.wait_for_timeout(5000)
            page.screenshot(path=out, full_page=False,
                            clip={"x": 530, "y": 45, "width": 860, "height": 1200})  # fmt: skip
            page.close()


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "faceplate_tuning.png")
