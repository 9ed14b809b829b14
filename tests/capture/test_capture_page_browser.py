"""The technician's page in headless Chromium (Selenium, Debian's chromium-driver) during a
simulated capture: rows appear as points are accepted, a source that stops sending shows
its banner, and a reading typed on the page is stored in the session."""

from __future__ import annotations

import json
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest

from timing import scaled_timeout

pytest.importorskip("aiohttp", reason="the capture extra (aiohttp) is not installed")
webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")

from volcal.capture.page.server import Page  # noqa: E402
from volcal.capture.simulated import SimulatedControl  # noqa: E402
from volcal.capture.sources import SourceError, register_control  # noqa: E402
from volcal.plan.planner import plan_session  # noqa: E402
from volcal.session.format import write_session  # noqa: E402
from volcal.steps.capture import capture  # noqa: E402

pytestmark = pytest.mark.browser

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
FLAGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage"]


class _Gate:
    """What the test does to the control: silence it, or make it fail (ends the capture)."""

    def __init__(self) -> None:
        self.silent = threading.Event()
        self.fail = threading.Event()


GATE = _Gate()


class GatedControl(SimulatedControl):
    """The simulated control, silenced or failed on the test's word."""

    def poll(self):
        if GATE.fail.is_set():
            raise SourceError("the test ended the capture")
        s = super().poll()
        return None if GATE.silent.is_set() else s


register_control("gated-sim", GatedControl, "test: the simulated control, gated",
                 simulated=True)


@pytest.fixture(scope="module")
def browser():
    if not Path(CHROMIUM).exists() or not Path(CHROMEDRIVER).exists():
        pytest.skip("chromium or chromedriver is missing (make browser-deps installs them)")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = CHROMIUM
    for f in FLAGS:
        opts.add_argument(f)
    opts.add_argument("--window-size=820,1180")  # a tablet held upright
    drv = webdriver.Chrome(options=opts, service=Service(executable_path=CHROMEDRIVER))
    drv.set_page_load_timeout(scaled_timeout(20.0))
    try:
        yield drv
    finally:
        drv.quit()


@pytest.fixture
def session(tmp_path):
    s = plan_session(np.array([[0, 100], [0, 100], [0, 100]], float), "XYFZ", 2,
                     ("linear:x",), 1, name="PAGE-VMC")
    folder = tmp_path / "session"
    write_session(s, folder)
    return folder, s.measurements[0].id


def _wait(drv, script, nominal_s=10.0, what=""):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(drv, scaled_timeout(nominal_s), poll_frequency=0.1).until(
        lambda d: d.execute_script(script), message=what)


def _run(folder, mid, laser, page, **kw):
    out: dict = {}

    def go():
        try:
            out["result"] = capture(folder, control="gated-sim", laser=laser,
                                    measurement=[mid], observer=page.observer,
                                    extras=page.extras, **kw)
        except Exception as e:  # reported by the test
            out["error"] = e

    th = threading.Thread(target=go, daemon=True)
    th.start()
    return th, out


def _table(drv, rows: int) -> tuple[list[str], list[list], str]:
    """Once the page shows ``rows`` accepted rows: the table's headings, each accepted row
    (its reading, then its cells' texts) and the plot's unit line."""
    _wait(drv, "const r = document.querySelectorAll('#points tr.accepted');"
               f"return r.length >= {rows} ? r.length : false;", 30.0, "rows")
    heads = drv.execute_script(
        "return Array.from(document.querySelectorAll('#points thead th'))"
        ".map(h => h.textContent);")
    shown = drv.execute_script(
        "return Array.from(document.querySelectorAll('#points tr.accepted'))"
        ".map(r => [Number(r.dataset.reading), ...Array.from(r.cells, c => c.textContent)]);")
    return heads, shown, drv.find_element("id", "plot-unit").text


def _finish(th, out, page):
    GATE.fail.set()
    th.join(scaled_timeout(20.0))
    page.close()
    GATE.fail.clear()
    GATE.silent.clear()
    assert not th.is_alive()
    assert "error" not in out, out.get("error")
    return out["result"]


def test_rows_appear_and_a_silent_source_shows_its_banner(browser, session):
    folder, mid = session
    page = Page("PAGE-VMC", "gated-sim", "sim", port=0)
    th, out = _run(folder, mid, "sim", page, speed=8.0)
    try:
        browser.get(page.url)
        n = _wait(browser, "const r = document.querySelectorAll('#points tr.accepted');"
                           "return r.length >= 2 ? r.length : false;", 20.0, "rows")
        assert n >= 2
        # the plot grows with them
        assert browser.execute_script("return document.querySelectorAll('#plot circle').length"
                                      ) >= 2
        # the rows show the values written to the session's CSV
        shown = browser.execute_script(
            "return Array.from(document.querySelectorAll('#points tr.accepted'))"
            ".map(r => [Number(r.dataset.reading), r.cells[7].textContent]);")
        GATE.silent.set()
        _wait(browser, "return document.getElementById('banners').dataset.control === 'stale'"
                       " && document.getElementById('banners').textContent;", 10.0, "banner")
        text = browser.find_element("id", "banners").text
        assert "control source gated-sim stopped sending" in text
    finally:
        _finish(th, out, page)
    csv = (folder / f"{mid}.csv").read_text(encoding="utf-8").splitlines()
    head = csv[0].split(",")
    col = head.index("deviation_um")
    for reading, cell in shown:
        value = float(csv[reading + 1].split(",")[col])
        assert cell == f"{value:.3f} um"


def test_a_typed_reading_is_stored_in_the_session(browser, session):
    folder, mid = session
    page = Page("PAGE-VMC", "gated-sim", "typed", port=0)
    # real time; a dwell long enough to type in (the page's use with typed readings)
    th, out = _run(folder, mid, "typed", page, speed=1.0, dwell_s=8.0)
    try:
        browser.get(page.url)
        _wait(browser, "return !document.getElementById('typed-form').hidden;", 10.0, "form")
        _wait(browser, "return document.getElementById('stability-text').textContent"
                       " === 'at target';", 20.0, "at the first target")
        box = browser.find_element("id", "typed-value")
        box.send_keys("12.5")
        browser.find_element("id", "typed-submit").click()
        _wait(browser, "return document.querySelector('#points tr.accepted') !== null;", 10.0,
              "the typed reading accepted")
        log = browser.find_element("id", "typed-log").text
        assert "12.5000 um" in log and "taken" in log
    finally:
        _finish(th, out, page)
    # the journal holds the typed value as the reading; the CSV holds its row (the first
    # row is the reference of a linear test's deviations: 0 by definition)
    lines = (folder / "capture" / f"{mid}.jsonl").read_text(encoding="utf-8").splitlines()
    accepted = [r for r in map(json.loads, lines) if r["type"] == "accepted"]
    assert len(accepted) == 1
    assert accepted[0]["reading"] == 0 and accepted[0]["value"] == 12.5
    row = (folder / f"{mid}.csv").read_text(encoding="utf-8").splitlines()[1].split(",")
    head = (folder / f"{mid}.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert float(row[head.index("deviation_um")]) == 0.0


def test_an_r_test_shows_every_axis_of_its_poses_and_the_three_sensors(browser, tmp_path):
    """Session 22: the page headed an R-test's targets X, Y, Z [mm] (its rotary angles not
    shown), gave the first sensor alone as the reading and plotted it against a "position
    along the line [mm]" mixing mm and deg."""
    from volcal.steps.plan import plan

    folder = tmp_path / "rt"
    plan(((0.0, 400.0), (0.0, 300.0), (0.0, 250.0)), steps=2, tests="r_test:ca",
         output=folder)
    page = Page("PAGE-RT", "gated-sim", "sim:seed=3", port=0)
    th, out = _run(folder, "r_test", "sim:seed=3", page, speed=8.0)
    try:
        browser.get(page.url)
        heads, shown, label = _table(browser, 2)
    finally:
        _finish(th, out, page)
    assert heads[:4] == ["#", "X [mm]", "Y [mm]", "Z [mm]"]
    assert sorted(heads[4:6]) == ["A [deg]", "C [deg]"]
    assert heads[6:] == ["run", "dir", "status", "reading"]
    assert label.endswith("against the pose")
    csv = (folder / "r_test.csv").read_text(encoding="utf-8").splitlines()
    head = csv[0].split(",")
    cols = [head.index(c) for c in ("dx_um", "dy_um", "dz_um")]
    for reading, *cells in shown:
        row = csv[reading + 1].split(",")
        assert cells[-1] == " / ".join(f"{float(row[c]):.3f}" for c in cols) + " um"


def test_a_rotary_test_shows_its_angles_and_its_readings_in_urad(browser, tmp_path):
    """A rotary test (C axis, ``volcal capture --control sim --laser sim``): the page heads
    its targets C [deg] (no X, Y, Z), shows each reading in urad as the CSV holds it,
    plots them against the angle, and offers urad for a typed reading."""
    from volcal.steps.plan import plan

    folder = tmp_path / "rot"
    plan(((0.0, 400.0), (0.0, 300.0), (0.0, 250.0)), steps=4, tests="rotary:c", runs=1,
         output=folder)
    page = Page("PAGE-ROT", "gated-sim", "sim:seed=3", port=0)
    th, out = _run(folder, "rotary-c", "sim:seed=3", page, speed=8.0)
    try:
        browser.get(page.url)
        heads, shown, label = _table(browser, 3)
        typed_unit = browser.execute_script("return document.getElementById('typed-unit').value;")
    finally:
        _finish(th, out, page)
    assert heads == ["#", "C [deg]", "run", "dir", "status", "reading"]
    assert label == "[urad] against the angle from the first target [deg]"
    assert typed_unit == "urad"
    csv = (folder / "rotary-c.csv").read_text(encoding="utf-8").splitlines()
    head = csv[0].split(",")
    col, tgt = head.index("deviation_urad"), head.index("target_deg")
    assert len(shown) >= 3
    for reading, *cells in shown:
        row = csv[reading + 1].split(",")
        assert cells[1] == f"{float(row[tgt]):.3f}"  # after the row's number
        assert cells[-1] == f"{float(row[col]):.3f} urad"
