"""The faceplate in a real browser: headless Chromium (Debian's) driven by Playwright.

Each test serves a fresh runtime (the fast lag plant of ``conftest``) on
127.0.0.1 and stops it at the end.  The screenshot of the first test is saved
to ``$CTRLBLOCKS_ARTIFACTS`` (default: a pytest temporary directory), never
into the repository.
"""

from __future__ import annotations

import itertools
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
    USERS,
    chromium_context,
    make_runtime,
    make_users,
    pi_step_bound,
    running_server,
)

# the faceplate in a real browser: end to end, about a minute of CPU, run with the long
# campaigns (pytest -m slow; CI runs them); the API tests cover the same routes in the default run
pytestmark = [pytest.mark.filterwarnings("ignore::DeprecationWarning"), pytest.mark.slow]


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


def log_in(page: Any, user: str = OPERATOR[0]) -> None:
    page.fill("#login-user", user)
    page.fill("#login-password", USERS[user][1])
    page.click("#btn-login")
    page.wait_for_function("u => window.faceplate.user === u", arg=user)
    assert page.text_content("#who") == user
    assert page.text_content("#role") == USERS[user][0]


def log_out(page: Any) -> None:
    page.click("#btn-logout")
    page.wait_for_function("() => window.faceplate.user === null")


def disabled(page: Any) -> dict[str, bool]:
    """Which controls are disabled, by element id (and ``tunings`` for the tuning inputs)."""
    return js(
        page,
        """Object.fromEntries([
             ...['btn-auto', 'btn-man', 'manual-value', 'btn-manual', 'sp-input', 'btn-sp', 'umin',
                 'umax', 'btn-limits', 'btn-tunings'].map(id => [id, $(id).disabled]),
             ['tunings', [...document.querySelectorAll('#tunings input')].every(i => i.disabled)]
           ])""",
    )


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
    # the product's name once (the issue read "ctrlblocks — ctrlblocks demo")
    assert page.text_content("#rt-name") == "ctrlblocks — faceplate test"
    assert page.title() == "ctrlblocks — faceplate test · faceplate"
    assert js(page, "faceplate.titles('ctrlblocks demo')") == [
        "ctrlblocks demo", "ctrlblocks demo · faceplate"]  # fmt: skip
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


def test_without_login_every_control_is_disabled_and_the_server_refuses(
    page: Any, url: str
) -> None:
    assert page.is_visible("#login-form")
    assert all(disabled(page).values()), disabled(page)
    assert "you can only watch" in page.text_content("#role-note")
    assert not page.is_visible("#audit-box") and not page.is_visible("#history-box")
    # what the page does not offer, the server refuses all the same
    r = page.request.post(f"{url}api/loops/fast/command", data={"sp": 1.4})
    assert r.status == 401
    assert server_state(page, url, "fast")["sp"] == 1.0


def test_units_ranges_and_a_trend_axis_that_keeps_the_sp_in_view(page: Any) -> None:
    assert [page.text_content(f"#u-{s}") for s in ("sp", "pv", "mv")] == ["m", "m", "%"]
    assert page.text_content("#loops tr[data-loop=fast] td.pv").endswith(" m")
    assert page.text_content("#loops tr[data-loop=fast] td.mv").endswith(" %")
    assert page.text_content("#r-sp") == "0 … 2 m"
    assert page.text_content("#r-manual") == "0 … 5 %"  # the block's limits: no mv_range given
    assert page.text_content("#r-limits") == "within 0 … 5 %"
    assert page.text_content("#tunings tr[data-key=kp] td.range") == "0.1 … 10"
    # derived from the loop: 0 (no integral) or a tenth of ts = 0.05 s up to 10^4 ts
    assert page.text_content("#tunings tr[data-key=ti] td.range") == "0 or 0.005 … 500 s"
    # the ADRC's order: its three values (the issue read "> 0")
    page.click("#loops tr[data-loop=level]")
    page.wait_for_function("() => document.querySelector('#plate-title').textContent === 'level'")
    page.wait_for_selector("#tunings tr[data-key=order]")
    assert page.text_content("#tunings tr[data-key=order] td.range") == "1, 2, 3"
    page.click("#loops tr[data-loop=fast]")
    page.wait_for_function("() => document.querySelector('#plate-title').textContent === 'fast'")
    # steady state SP = PV = 1 m: the axis shows the SP and at least 5 % of [0, 2] m
    wait_cycles(page, "fast", 5)
    lo, hi = js(page, "[faceplate.chart.scales.y.min, faceplate.chart.scales.y.max]")
    assert lo < 1.0 < hi and hi - lo >= 0.05 * 2.0
    assert js(page, "faceplate.yRange(0.9999, 1.0001, 'sp')") == pytest.approx([0.945, 1.055])
    assert js(page, "faceplate.yRange(0.2, 0.3, 'sp')") == pytest.approx([0.2 - 0.04, 1.0 + 0.04])


def test_each_role_sees_only_its_controls_enabled(page: Any) -> None:
    log_in(page, "vera")
    assert all(disabled(page).values())
    assert page.is_visible("#audit-box") and page.is_visible("#history-box")
    log_out(page)
    log_in(page, "bob")
    d = disabled(page)
    assert not any(d[k] for k in ("btn-auto", "btn-man", "manual-value", "btn-sp", "sp-input"))
    assert all(d[k] for k in ("umin", "umax", "btn-limits", "btn-tunings", "tunings"))
    assert "need an engineer" in page.text_content("#role-note")
    log_out(page)
    log_in(page)
    assert not any(disabled(page).values())


def test_a_large_step_asks_first_and_the_range_is_enforced(page: Any, url: str) -> None:
    log_in(page)
    page.fill("#sp-input", "1.1")  # 0.1 m: within 10 % of the 2 m range, sent at once
    page.click("#btn-sp")
    wait_message(page, "setpoint accepted")
    page.fill("#sp-input", "1.6")  # 0.5 m: asks first
    page.click("#btn-sp")
    page.wait_for_selector("#confirm", state="visible")
    assert page.text_content("#confirm-text").startswith("Setpoint 1.100 → 1.600 m")
    page.click("#confirm-no")
    wait_message(page, "setpoint not sent (cancelled)")
    assert server_state(page, url, "fast")["sp"] == 1.1
    page.click("#btn-sp")
    page.click("#confirm-yes")
    wait_message(page, "setpoint accepted")
    assert server_state(page, url, "fast")["sp"] == 1.6
    # outside the range: marked at once, refused by the server with the field and the range
    page.fill("#sp-input", "2.5")
    assert "out" in page.get_attribute("#sp-input", "class")
    page.click("#btn-sp")
    page.click("#confirm-yes")
    msg = wait_message(page, "setpoint refused")
    assert "sp: outside the engineering range [0, 2], got 2.5 m" in msg
    page.fill("#umin", "-50")
    page.fill("#umax", "-10")
    page.click("#btn-limits")
    assert "u_min: outside the engineering range [0, 5]" in wait_message(page, "limits refused")
    st = server_state(page, url, "fast")
    assert (st["sp"], st["u_min"], st["u_max"]) == (1.6, 0.0, 5.0)


@pytest.mark.parametrize("size", [(1280, 800), (390, 844)])
def test_the_page_fits_a_desktop_and_a_phone(browser: Any, url: str, size: tuple[int, int]) -> None:
    p = browser.new_page()
    try:
        p.set_viewport_size({"width": size[0], "height": size[1]})
        p.goto(url)
        p.wait_for_function("() => window.faceplate && window.faceplate.updates > 0")
        # nothing sticks out sideways; the SP controls and the trend are on the screen
        assert js(p, "document.documentElement.scrollWidth") <= size[0]
        for sel in ("#sp-input", "#btn-sp", "#trend .u-over", "#v-pv"):
            box = p.locator(sel).bounding_box()
            assert box is not None and box["x"] >= 0 and box["x"] + box["width"] <= size[0], sel
    finally:
        p.close()


def test_a_viewer_sees_the_history_and_downloads_it_as_csv(page: Any, url: str) -> None:
    log_in(page, "vera")
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
    assert lines[0].startswith("t_wall [s],run_id,cycle,t [s],dt [s],sp [m],pv [m],mv [%],mode")
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
    page.click("#confirm-yes")  # 0.5 m is more than 10 % of the 2 m range: asked first
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


def test_a_private_faceplate_shows_the_loops_only_after_a_login(browser: Any, tmp_path: Path):
    with running_server(make_runtime(tmp_path, public_view=False), make_users(tmp_path)) as url:
        browser.clear_cookies()
        p = browser.new_page()
        p.set_default_timeout(20_000)
        try:
            p.goto(url)
            p.wait_for_function("() => window.faceplate && window.faceplate.info !== null")
            assert p.is_visible("#login-needed") and not p.is_visible("main")
            assert js(p, "faceplate.updates") == 0 and js(p, "faceplate.ws") is None
            log_in(p, "vera")
            p.wait_for_function("() => window.faceplate.updates > 0")  # the live view connects
            assert not p.is_visible("#login-needed")
            assert p.text_content("#loops tr[data-loop=fast] td.name") == "fast"
            log_out(p)
            p.wait_for_function("() => document.querySelector('#login-needed').offsetParent")
            p.wait_for_function("() => window.faceplate.ws === null")  # the server closed it
        finally:
            p.close()


def test_an_engineer_runs_a_live_tuning_from_the_panel_and_rejects_it(page: Any) -> None:
    log_in(page, "bob")
    assert js(page, "$('tune-start').disabled")  # an operator may not tune
    log_out(page)
    log_in(page)
    page.click("#tune-box summary")
    page.select_option("#tune-method", "step")
    page.fill("#tune-amplitude", "0.5")
    page.fill("#tune-pv-max", "1.9")
    page.click("#tune-start")
    wait_message(page, "step test accepted")
    page.wait_for_function(
        "() => document.querySelector('#tune-status').textContent.includes('step test running')"
    )
    page.wait_for_function(
        "() => document.querySelector('#tune-status').textContent === 'step test done'"
        " && !document.querySelector('#tune-proposals').textContent.includes('computing')",
        timeout=40_000,
    )
    assert "model: FOPDT gain 1.0" in page.text_content("#tune-model")  # the lag: k = 1
    rows = page.locator("#tune-proposals tbody tr")
    assert rows.count() >= 2 and rows.first.get_attribute("data-proposal") == "PID_AMIGO"
    # a lag without dead time: the model rules' gains make the loop unstable, shown so
    assert "UNSTABLE" in rows.first.text_content()
    page.click("#tune-reject")
    wait_message(page, "reject accepted")
    assert page.text_content("#tune-status") == "step test rejected by alice"
    assert rows.first.locator("button").count() == 0  # nothing left to accept


def _background(page: Any, selector: str) -> str:
    return js(page, f"getComputedStyle(document.querySelector({selector!r})).backgroundColor")


@pytest.mark.parametrize("size", [(1280, 800), (390, 844)])
def test_a_loop_in_trouble_shows_its_state_in_words_and_colour(
    browser: Any, tmp_path: Path, size: tuple[int, int]
) -> None:
    """The issue: a loop on its safe value showed green "AUTO", its alarm one technical
    string, off-screen at phone width.  Now: the mode turns red, the words "bad PV" and
    "on safe value" stand in the row (and on the faceplate), on a desktop and a phone."""
    rt = make_runtime(tmp_path)
    bus = rt.connections["sim"].adapter.bus
    with running_server(rt, make_users(tmp_path)) as url:
        p = browser.new_page()
        p.set_viewport_size({"width": size[0], "height": size[1]})
        p.set_default_timeout(20_000)
        try:
            p.goto(url)
            p.wait_for_function("() => window.faceplate && window.faceplate.updates > 2")
            row = "#loops tr[data-loop=fast]"
            assert p.text_content(f"{row} td.mode") == "AUTO"
            # all well: green (a loaded machine may stretch a period: amber, a warning)
            assert _background(p, f"{row} td.mode") in ("rgb(211, 249, 216)", "rgb(255, 243, 191)")
            assert not js(p, f"document.querySelector({row!r}).classList.contains('alarm')")
            bus.bad.add("fast.pv")  # the sensor fails: the PID writes its safe value
            p.wait_for_function(
                "() => document.querySelector('#loops tr[data-loop=fast]')"
                ".classList.contains('alarm')"
            )
            words = p.locator(f"{row} td.state .st").all_text_contents()
            assert {"bad PV", "on safe value"} <= set(words)
            assert p.text_content(f"{row} td.mode") == "AUTO"  # the mode it is in, in red
            assert _background(p, f"{row} td.mode") == "rgb(255, 227, 227)"
            assert _background(p, f"{row} td.state .st.alarm") == "rgb(201, 42, 42)"
            # the words are on the screen, at phone width too, and on the faceplate
            box = p.locator(f"{row} td.state").bounding_box()
            assert box is not None and box["x"] >= 0 and box["x"] + box["width"] <= size[0]
            assert js(p, "document.documentElement.scrollWidth") <= size[0]
            items = p.locator("#plate-alarms li").all_text_contents()
            assert any(t.startswith("bad PV: PV bad: bad quality") for t in items), items
            bus.bad.discard("fast.pv")  # back: the words go
            p.wait_for_function(
                "() => !document.querySelector('#loops tr[data-loop=fast] td.state')"
                ".textContent.includes('bad PV')"
            )
        finally:
            p.close()


def test_the_time_axis_labels_do_not_overlap(page: Any) -> None:
    """The issue saw '12/3/26 7:13pm7:14pm': labels drawn into each other."""
    for window in ("30", "120", "300"):
        page.select_option("#trend-window", window)
        page.wait_for_function("() => faceplate.chart.axes[0]._values")
        boxes = js(
            page,
            """(() => {
                const u = faceplate.chart, ax = u.axes[0];
                const ctx = document.createElement('canvas').getContext('2d');
                ctx.font = ax.font[0];
                return ax._splits.map((v, i) => {
                  const x = u.valToPos(v, 'x');
                  const w = Math.max(...String(ax._values[i]).split('\\n')
                                          .map((l) => ctx.measureText(l).width));
                  return [x - w / 2, x + w / 2];
                });
              })()""",
        )
        assert len(boxes) >= 2
        for (_, right), (left, _) in itertools.pairwise(boxes):
            assert right < left, (window, boxes)
    labels = js(page, "faceplate.timeLabels(null, [0, 3600, 90000], 0, 0, 60)")
    assert labels[0].count("\n") == 1 and "\n" not in labels[1]  # the date once, then per day
    assert labels[2].count("\n") == 1
