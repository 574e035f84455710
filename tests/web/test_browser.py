"""The faceplate in a real browser: headless Chromium (Debian's) driven by Playwright.

Each test serves a fresh runtime (the fast lag plant of ``conftest``) on
127.0.0.1 and stops it at the end.  The screenshot of the first test is saved
to ``$CTRLBLOCKS_ARTIFACTS`` (default: a pytest temporary directory), never
into the repository.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("playwright")

from ctrlblocks.blocks.base import ErrorCode

from .conftest import (
    OPERATOR,
    chromium_context,
    make_runtime,
    make_users,
    pi_step_bound,
    running_server,
)

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def browser() -> Any:
    with chromium_context() as ctx:
        yield ctx


@pytest.fixture
def url(tmp_path: Path) -> Any:
    with running_server(make_runtime(tmp_path), make_users(tmp_path)) as u:
        yield u


@pytest.fixture
def page(browser: Any, url: str) -> Any:
    browser.clear_cookies()
    p = browser.new_page()
    p.set_default_timeout(20_000)
    errors: list[str] = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    p.goto(url)
    p.wait_for_function("() => window.faceplate && window.faceplate.updates > 0")
    yield p
    p.close()
    assert errors == [], errors  # no JavaScript error on the page


def artifacts(tmp_path_factory: Any) -> Path:
    d = os.environ.get("CTRLBLOCKS_ARTIFACTS")
    out = Path(d) if d else tmp_path_factory.mktemp("artifacts")
    out.mkdir(parents=True, exist_ok=True)
    return out


def js(page: Any, expr: str) -> Any:
    return page.evaluate(f"() => {expr}")


def log_in(page: Any) -> None:
    page.fill("#login-user", OPERATOR[0])
    page.fill("#login-password", OPERATOR[1])
    page.click("#btn-login")
    page.wait_for_function("() => window.faceplate.user === 'alice'")
    assert page.text_content("#who") == "alice"


def wait_message(page: Any, text: str) -> str:
    """Wait until the message line contains ``text``; return the whole message."""
    page.wait_for_function("t => document.querySelector('#msg').textContent.includes(t)", arg=text)
    return page.text_content("#msg")


def wait_cycles(page: Any, loop: str, n: int) -> None:
    c = js(page, f"faceplate.states[{loop!r}].cycle")
    page.wait_for_function("([l, c]) => window.faceplate.states[l].cycle >= c", arg=[loop, c + n])


def server_state(page: Any, url: str, loop: str) -> dict[str, Any]:
    return page.request.get(f"{url}api/loops/{loop}").json()


def test_page_shows_the_loops_and_the_trend_moves(page: Any, tmp_path_factory: Any) -> None:
    rows = page.locator("#loops tbody tr")
    page.wait_for_function("() => document.querySelectorAll('#loops tbody tr').length === 2")
    assert [rows.nth(i).get_attribute("data-loop") for i in range(2)] == ["fast", "level"]
    assert page.text_content("#loops tr[data-loop=fast] td.mode") == "AUTO"
    assert page.text_content("#plate-title") == "fast"  # the first loop is shown
    n0 = js(page, "faceplate.data.fast.t.length")
    x0 = js(page, "faceplate.chart.scales.x.max")
    # 20 more samples (1 s at 20 Hz) arrive and the time axis follows them
    page.wait_for_function("n => window.faceplate.data.fast.t.length >= n + 20", arg=n0)
    page.wait_for_function("x => window.faceplate.chart.scales.x.max > x + 0.5", arg=x0)
    assert js(page, "faceplate.chart.data[0].length") >= n0 + 20
    assert float(page.text_content("#v-pv")) == pytest.approx(1.0, abs=1e-3)
    # pan: half a window (2 min) back; zoom: drag across the chart; Live follows again
    lo, hi = js(page, "[faceplate.chart.scales.x.min, faceplate.chart.scales.x.max]")
    page.click("#pan-left")
    lo2, hi2 = js(page, "[faceplate.chart.scales.x.min, faceplate.chart.scales.x.max]")
    assert js(page, "faceplate.follow") is False
    assert hi2 - lo2 == pytest.approx(120.0)
    assert (lo2, hi2) == (pytest.approx(lo - 60.0, abs=2.0), pytest.approx(hi - 60.0, abs=2.0))
    box = page.locator("#trend .u-over").bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + 0.25 * box["width"], y)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.5 * box["width"], y, steps=5)
    page.mouse.up()
    lo3, hi3 = js(page, "[faceplate.chart.scales.x.min, faceplate.chart.scales.x.max]")
    assert hi3 - lo3 == pytest.approx(0.25 * 120.0, rel=0.05)  # a quarter of the window
    assert lo3 == pytest.approx(lo2 + 0.25 * 120.0, abs=2.0)
    page.click("#btn-live")
    assert js(page, "faceplate.follow") is True
    page.wait_for_function("x => window.faceplate.chart.scales.x.max >= x", arg=hi)
    shot = artifacts(tmp_path_factory) / "faceplate.png"
    page.screenshot(path=str(shot), full_page=True)
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000


def test_a_change_without_login_is_refused(page: Any, url: str) -> None:
    assert page.is_visible("#login-form")
    page.fill("#sp-input", "1.4")
    page.click("#btn-sp")
    msg = wait_message(page, "setpoint refused")
    assert "log in as an operator" in msg
    assert page.get_attribute("#msg", "class") == "refused"
    assert server_state(page, url, "fast")["sp"] == 1.0
    page.click("#audit-box summary")
    page.wait_for_selector("#audit tbody tr.refused")
    assert page.text_content("#audit tbody tr td:nth-child(2)") == "anonymous"


def test_a_viewer_sees_the_history_and_downloads_it_as_csv(page: Any, url: str) -> None:
    wait_cycles(page, "fast", 10)
    page.click("#history-box summary")
    page.click("#btn-history")
    page.wait_for_function(
        "() => /^[0-9]+ samples/.test(document.querySelector('#hist-info').textContent)"
    )
    n = int(page.text_content("#hist-info").split()[0])
    assert n >= 10
    assert js(page, "faceplate.histChart.data[0].length") == n
    href = page.get_attribute("#csv-link", "href")
    assert href.startswith("api/loops/fast/history.csv?start=")
    with page.expect_download() as dl:
        page.click("#csv-link")
    lines = Path(dl.value.path()).read_text().splitlines()
    assert lines[0].startswith("t_wall,run_id,cycle,t,dt,sp,pv,mv,mode")
    assert len(lines) >= n + 1  # every sample of the period (the plot may thin them)


def test_operator_switches_to_man_and_back_without_a_bump(page: Any, url: str) -> None:
    log_in(page)
    t0 = time.time()
    page.click("#btn-man")
    page.wait_for_function(
        "() => document.querySelector('#loops tr[data-loop=fast] td.mode').textContent === 'MAN'"
    )
    wait_cycles(page, "fast", 2)
    page.fill("#manual-value", "1.3")
    page.click("#btn-manual")
    page.wait_for_function("() => window.faceplate.states.fast.pv > 1.1")
    page.click("#btn-auto")
    page.wait_for_function(
        "() => document.querySelector('#loops tr[data-loop=fast] td.mode').textContent === 'AUTO'"
    )
    wait_cycles(page, "fast", 5)
    # the recorded MV, from the historian
    h = page.request.get(
        f"{url}api/loops/fast/history",
        params={"start": t0 - 1, "end": time.time() + 1, "max_points": 100000},
    ).json()["columns"]
    mv, mode = h["mv"], h["mode"]
    k_man, k_auto = (k for k in range(1, len(mode)) if mode[k] != mode[k - 1])
    assert (mode[k_man], mode[k_auto]) == ("manual", "auto")
    assert mv[k_man] == pytest.approx(mv[k_man - 1], abs=1e-9)  # into MAN: no bump
    assert mv[k_auto - 1] == pytest.approx(1.3, abs=1e-12)  # the operator's manual value
    # into AUTO: the output continues from 1.3, each step at most one PI increment
    # (a restart from the old integrator would jump by about 0.4)
    for k in range(k_auto, len(mv)):
        assert abs(mv[k] - mv[k - 1]) <= pi_step_bound(h, k), k
    assert pi_step_bound(h, k_auto) < 0.2


def test_operator_changes_the_setpoint_and_the_pv_follows(page: Any, url: str) -> None:
    log_in(page)
    page.fill("#sp-input", "1.5")
    page.click("#btn-sp")
    wait_message(page, "fast: setpoint accepted")
    assert page.get_attribute("#msg", "class") == "ok"
    assert server_state(page, url, "fast")["sp"] == 1.5
    # closed loop: first-order, time constant 0.5 s -> 90 % after 1.15 s
    page.wait_for_function("() => window.faceplate.states.fast.pv > 1.45")
    page.wait_for_function("() => parseFloat(document.querySelector('#v-pv').textContent) > 1.45")
    assert float(page.text_content("#v-sp")) == 1.5


def test_a_refused_tuning_shows_the_blocks_error_code(page: Any, url: str) -> None:
    log_in(page)
    page.fill("#tunings input[data-key=kp]", "-1")
    page.click("#btn-tunings")
    msg = wait_message(page, "tuning kp refused")
    code = ErrorCode.BAD_PID_COEFFS
    assert f"16#{int(code):04X} {code.name}: tunings.kp: must be > 0" in msg
    assert server_state(page, url, "fast")["tunings"]["kp"] == 1.0
    page.fill("#tunings input[data-key=kp]", "2")
    page.click("#btn-tunings")
    wait_message(page, "tuning kp accepted")
    assert server_state(page, url, "fast")["tunings"]["kp"] == 2.0
    page.wait_for_function(
        "() => document.querySelector('#tunings tr[data-key=kp] td').textContent === '2'"
    )
