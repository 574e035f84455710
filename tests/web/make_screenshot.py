"""Take the screenshot of docs/faceplate.md: the demo of ``ctrlblocks serve`` in Chromium.

Run from the repository root (about 50 s of real time)::

    .venv/bin/python -m tests.web.make_screenshot docs/figures/faceplate.png \
        docs/figures/faceplate-phone.png

It serves the demo (simulated three-tank ADRC loop and PI flow loop) on
127.0.0.1, logs in as a temporary operator, raises the pressure setpoint from
1.5 to 1.8 bar through the page (confirming the step if the page asks), lets
the loop answer for 30 s and saves the page; then, at phone width, the
pressure loop's sensor fails and the page is saved again (the loop's state
in words and colour).  Not a test (pytest does not collect it).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from ctrlblocks.web import UserStore
from ctrlblocks.web.demo import demo_runtime

from .conftest import chromium_context, running_server


def main(out: str, phone: str | None = None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        runtime, sim = demo_runtime(Path(tmp) / "history.sqlite")
        users = UserStore(Path(tmp) / "users.json")
        users.add("operator1", "demo password", n=2**10)
        with running_server(runtime, users) as url, chromium_context((1400, 980)) as browser:
            page = browser.new_page()
            page.goto(url + "#pressure")
            page.wait_for_function("() => window.faceplate && window.faceplate.updates > 5")
            page.wait_for_timeout(6000)  # some steady trend before the step
            page.fill("#login-user", "operator1")
            page.fill("#login-password", "demo password")
            page.click("#btn-login")
            page.wait_for_function("() => window.faceplate.user === 'operator1'")
            page.fill("#sp-input", "1.8")
            page.click("#btn-sp")
            if page.is_visible("#confirm"):  # a step above confirm_step of the range asks first
                page.click("#confirm-yes")
            page.wait_for_selector("#msg.ok")
            page.wait_for_timeout(30_000)
            page.click("#audit-box summary")
            page.wait_for_timeout(500)
            page.screenshot(path=out, full_page=False)
            if phone is not None:
                page.set_viewport_size({"width": 390, "height": 844})
                sim.bus.bad.add("pressure.pv")  # the sensor fails: the safe value goes out
                page.wait_for_timeout(3000)
                page.screenshot(path=phone, full_page=False)
            page.close()


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "faceplate.png",
         sys.argv[2] if len(sys.argv) > 2 else None)  # fmt: skip
