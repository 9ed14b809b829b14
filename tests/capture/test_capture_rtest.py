"""``volcal capture`` of an R-test (session 21): the nest's three sensors at each pose.

The simulated control plays the R-test's program (:func:`volcal.program.r_test.
rtest_program_path`: the rotary axes turning with the linear axes following, a dwell at
each pose); the simulated laser is the nest: three channels, the sphere's displacement
that ``volcal simulate --seed`` would write for the machine it draws (its
``truth/setup.toml``), at the control's actual pose. Each test checks the capture against
that truth and against ``volcal simulate``'s own readings and ``volcal locate`` on them.
The plan is the default ``r_test:ca`` cut to 9 poses (a short rehearsal).
"""

from __future__ import annotations

import json
import shutil
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from volcal.capture.journal import journal_path, read_journal
from volcal.capture.page.state import LiveState
from volcal.capture.samples import CaptureEvent, LaserSample
from volcal.capture.sources import register_control, register_laser
from volcal.errors import VolcalInputError
from volcal.steps.capture import capture
from volcal_cli_helpers import run_volcal

from .conftest import FAST, FAST_CLI
from .fake_sources import NoRotary, Wrapped
from .rtest_plan import plan_rtest

TRAVEL = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))
SEED = 3
RT = "r_test"
COLS = ("dx_um", "dy_um", "dz_um")
# the poses kept of the default plan: C 0, 120, 240 at A 0 and -90, the A sweep at C 0
POSES = [(0, 0), (120, 0), (240, 0), (0, -45), (0, -90), (120, -90), (240, -90), (0, 45),
         (0, 90)]
N = len(POSES)
NOISE_UM = 0.5  # the test's noise_um: volcal simulate's noise on each component
# the capture's own error: 0.05 um of laser noise and the servo noise of 0.1 um / 0.0001 deg
# (0.35 um at the sphere's 200 mm) per sample, averaged over the 0.6 s window
TOL_UM = 0.5


def _readings(folder: Path) -> np.ndarray:
    from volcal.session.format import read_session

    m = read_session(folder).get(RT)
    return np.column_stack([m.columns[c] for c in COLS])


@pytest.fixture(scope="module")
def rt_planned(tmp_path_factory) -> Path:
    """The default R-test of a CA trunnion, cut to the 9 poses of :data:`POSES`."""
    return plan_rtest(tmp_path_factory.mktemp("rtest") / "S", TRAVEL, POSES)


@pytest.fixture(scope="module")
def simulated(rt_planned, tmp_path_factory) -> Path:
    """``volcal simulate --seed 3`` of a copy of the plan."""
    from volcal.steps.simulate import save, simulate

    sim = tmp_path_factory.mktemp("sim") / "S"
    shutil.copytree(rt_planned, sim)
    save(simulate(sim, seed=SEED), sim)
    return sim


@pytest.fixture(scope="module")
def exact(rt_planned, simulated) -> np.ndarray:
    """The exact readings of the simulation's truth (its machine, location errors, sphere)."""
    from volcal.kinds import kind_of
    from volcal.kinds.r_test import RTestSetup
    from volcal.session.errortable import read_error_table
    from volcal.session.format import read_session

    s = read_session(rt_planned, require_deviation=False)
    doc = tomllib.loads((simulated / "truth" / "setup.toml").read_text())["setup"][RT]
    setup = RTestSetup(doc["chain"], doc["location"], np.array(doc["sphere_mm"]))
    vm = read_error_table(simulated / "truth" / "machine.csv", chain=s.chain)
    return np.asarray(kind_of(RT).exact(vm, s.get(RT), setup))


@pytest.fixture(scope="module")
def captured(rt_planned, tmp_path_factory):
    """The R-test captured: ``volcal capture S --control sim --laser sim:seed=3``."""
    out = tmp_path_factory.mktemp("cap") / "C"
    r = capture(rt_planned, control="sim", laser=f"sim:seed={SEED}", output=out, **FAST)
    return out, r


def test_one_row_per_pose_as_volcal_simulate_reads_it(captured, rt_planned, simulated, exact):
    out, r = captured
    assert r.complete and [(o.measurement, o.accepted, o.missed, o.planned)
                           for o in r.outcomes] == [(RT, N, [], N)]
    got = _readings(out)  # the r_test kind's reader accepts the captured file
    assert np.max(np.abs(exact)) > 100.0  # hidden location errors of some 100 um
    assert np.max(np.abs(got - exact)) < TOL_UM, got - exact
    # volcal simulate's readings: the same truth with its noise of 0.5 um per component
    d = got - _readings(simulated)
    assert np.max(np.abs(d)) < 4 * NOISE_UM + TOL_UM, d
    assert 0.5 * NOISE_UM < float(np.sqrt(np.mean(d ** 2))) < 1.5 * NOISE_UM
    planned = (rt_planned / f"{RT}.csv").read_text().splitlines()
    rows = (out / f"{RT}.csv").read_text().splitlines()
    assert rows[0] == "c_deg,a_deg,x_mm,y_mm,z_mm,dx_um,dy_um,dz_um,time_s"
    assert [x.split(",")[:5] for x in rows[1:]] == [x.split(",")[:5] for x in planned[1:]]
    lines = [json.loads(x) for x in journal_path(out, RT).read_text().splitlines()]
    laser = [x for x in lines if x["type"] == "laser"]
    assert laser and all(len(x["ch"]) == 3 for x in laser)  # the nest's three sensors


def test_each_pose_is_matched_in_every_axis(captured, rt_planned):
    """The accepted window's mean pose: X, Y, Z within 10 um and C, A within 0.005 deg of
    the program's pose; the first pose's readings near zero (the sensors zeroed there)."""
    from volcal.session.format import read_session

    out, _ = captured
    m = read_session(rt_planned, require_deviation=False).get(RT)
    rec = read_journal(journal_path(out, RT))
    for i, a in sorted(rec.accepted.items()):
        want = [*m.positions[i], m.columns["c_deg"][i], m.columns["a_deg"][i]]
        assert np.allclose(a["pos"][:3], want[:3], atol=0.010), (i, a["pos"], want)
        assert np.allclose(a["pos"][3:], want[3:], atol=0.005), (i, a["pos"], want)
        assert len(a["values"]) == 3
    assert np.max(np.abs(_readings(out)[0])) < TOL_UM


def test_locate_gives_the_simulated_sessions_location_errors(captured, simulated,
                                                              monkeypatch, capsys):
    from volcal.session.format import read_session
    from volcal.steps.locate import locate

    out, _ = captured
    got = locate(read_session(out)).result
    want = locate(read_session(simulated)).result
    assert got.names == want.names and len(got.names) == 5
    for n in got.names:
        assert abs(got.estimate[n] - want.estimate[n]) <= 3 * np.hypot(got.u[n], want.u[n]), n
    assert max(abs(v) for v in got.estimate.values()) > 50.0  # errors of some 100 urad / um
    code, o, err = run_volcal(monkeypatch, capsys, "locate", str(out))
    assert code == 0 and "EB0A" in o and "Traceback" not in err


class _Blind(Wrapped):
    """The simulated nest, silent at the test's third pose (C = 240, A = 0)."""

    def alter(self, s: LaserSample) -> LaserSample | None:
        c = self.ctx.latest_control()
        if c is not None and abs(c.positions.get("C", 0) - 240.0) < 0.01 \
                and abs(c.positions.get("A", 0)) < 0.01:
            return None
        return s


def test_a_missed_pose_and_a_resume_keep_every_reading(rt_planned, captured, tmp_path):
    """The nest silent at pose 3: row 4 written ``missed`` in its three columns; a capture
    interrupted after 5 readings and resumed gives the uninterrupted capture's file."""
    from volcal.session.format import read_session

    register_laser("blind-rtest-test", _Blind, "the simulated nest, blind at one pose")
    out = tmp_path / "M"
    r = capture(rt_planned, control="sim", laser=f"blind-rtest-test:seed={SEED}", output=out,
                **FAST)
    assert r.complete and r.outcomes[0].missed == [4]
    row = (out / f"{RT}.csv").read_text().splitlines()[3].split(",")
    assert row[5:8] == ["missed"] * 3
    m = read_session(out).get(RT)
    assert m.n == N - 1
    assert np.allclose(_readings(out), np.delete(_readings(captured[0]), 2, axis=0), atol=1e-6)

    res = tmp_path / "R"
    seen: list[int] = []

    def stop_after_five(e: CaptureEvent) -> None:
        if e.kind == "accepted":
            seen.append(int(e.data["reading"]))
            if len(seen) == 5:
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        capture(rt_planned, control="sim", laser=f"sim:seed={SEED}", output=res,
                observer=stop_after_five, **FAST)
    partial = (res / f"{RT}.csv").read_text()
    page = LiveState("resumed")  # the technician's page follows the resumed capture
    r = capture(rt_planned, control="sim", laser=f"sim:seed={SEED}", output=res,
                observer=page, **FAST)
    assert r.complete and r.outcomes[0].replayed >= 5
    done = (res / f"{RT}.csv").read_text()
    assert done.splitlines()[:6] == partial.splitlines()[:6]  # never overwritten
    assert done == (captured[0] / f"{RT}.csv").read_text()
    # the page shows the three sensors of every pose, those recorded before the resume too
    (m,) = page.snapshot()["measurements"]
    assert m["columns"] == ["dx_um", "dy_um", "dz_um"]
    shown = np.array([d["values"] for d in m["dwells"]], float)
    assert np.allclose(shown, _readings(res), atol=1e-6)
    assert len(page.snapshot()["laser"]["channels"]) == 3


class _OneChannel(Wrapped):
    """The simulated nest sending its first sensor only (a laser of one channel)."""

    def alter(self, s):
        return replace(s, channels=())


def test_a_control_without_the_rotary_axes_or_a_one_channel_laser_is_refused(
        rt_planned, tmp_path, monkeypatch, capsys):
    register_control("xyz-only-rtest-test", NoRotary, "the simulated control, X Y Z only",
                     simulated=True)
    register_laser("one-channel-rtest-test", _OneChannel, "the simulated nest, one channel")
    with pytest.raises(VolcalInputError, match=r"the control sample has no axis 'C' \(axes: "
                                               r"X, Y, Z\); the R-test's program commands "
                                               r"X, Y, Z, C, A: it needs a control"):
        capture(rt_planned, control="xyz-only-rtest-test", laser="sim", output=tmp_path / "N",
                **FAST)
    with pytest.raises(VolcalInputError, match="the laser sends 1 value.s. per reading; "
                                               "r_test measurement needs 3"):
        capture(rt_planned, control="sim", laser="one-channel-rtest-test",
                output=tmp_path / "O", **FAST)
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(rt_planned), "--control",
                              "sim", "--laser", "sim:unit=urad", "-o", str(tmp_path / "V"),
                              *FAST_CLI)
    assert code == 2 and "sensors read lengths" in err and "Traceback" not in err


def test_the_plan_follows_the_programs_blocks(rt_planned):
    """The capture's dwells are the LinuxCNC program's G4 blocks, at the pose of the move
    before each (the program parsed here, in the test only); the one after the program's
    ``M0`` says so (:attr:`PlannedDwell.after_stop`)."""
    import re

    from volcal.capture.plan import plan_measurement, program_options
    from volcal.program.r_test import rtest_program
    from volcal.session.format import read_session

    s = read_session(rt_planned, require_deviation=False)
    m = s.get(RT)
    opts = program_options(dwell_s=2.0, safe_z_mm=500.0)
    pm = plan_measurement(m, s.travel, opts)
    text, _ = rtest_program(m, "linuxcnc", "T", 1, opts)
    here: dict[str, float] = {}
    poses, after_stop, last = [], [], ""
    for line in text.splitlines():
        for a, v in re.findall(r"\b([XYZCA])(-?[0-9.]+)", re.sub(r"\(.*?\)", "", line)):
            if not line.startswith("G53"):
                here[a] = float(v)
        if line.startswith("G4"):
            poses.append([here[a] for a in "XYZCA"])
            after_stop.append(last.startswith("M0"))
        if not line.startswith("("):  # (the dwell's comment names its pose)
            last = line
    assert len(pm.dwells) == N == len(poses)
    assert np.allclose([d.target for d in pm.dwells], poses, atol=1e-3)
    # the dwell the program reaches through its operator stop (pose 1), and no other
    assert [d.after_stop for d in pm.dwells] == after_stop == [True] + [False] * (N - 1)
    assert np.allclose(pm.start, poses[0]) and pm.frame.axes == ("X", "Y", "Z", "C", "A")


def test_a_stream_line_of_three_values_is_one_reading_of_three_channels():
    """``--laser stream:ADDRESS;channels=3``: the nest's ``dx,dy,dz`` on one line (the
    first three numbers, or three CSV columns from ``column``), in the line's unit; a line
    with fewer is no reading (counted unparsed)."""
    from volcal.capture.stream import LineParser

    p = LineParser({"channels": "3", "unit": "um"}, "stream:-;channels=3")
    s = p.parse("1.5 um, -2.25, 3e-1", 7.0)
    assert s is not None and s.channels == (1.5, -2.25, 0.3) and s.unit == "um"
    assert s.to_json()["ch"] == [1.5, -2.25, 0.3]
    p = LineParser({"channels": "3", "format": "csv", "column": "2", "unit": "mm",
                    "scale": "-1"}, "stream:-")
    s = p.parse("12.0,0.001,0.002,-0.003", 0.0)
    assert s is not None and s.values == (-0.001, -0.002, 0.003) and s.unit == "mm"
    assert p.parse("12.0,0.001", 0.0) is None and p.unparsed == 1
    with pytest.raises(VolcalInputError, match="channels='0': expected a count >= 1"):
        LineParser({"channels": "0"}, "stream:-")


def test_a_nest_sending_its_sensors_readings_is_written_as_the_displacement(rt_planned,
                                                                            captured, tmp_path):
    """With ``sensor_directions`` the nest's three values are the sensors' readings ``N d``:
    written into ``dx_um, dy_um, dz_um`` as ``N^-1 s``, the readings of a nest sending the
    displacement within the capture's noise."""
    s = tmp_path / "S"
    shutil.copytree(rt_planned, s)
    toml = (s / "session.toml").read_text()
    (s / "session.toml").write_text(toml.replace(
        "noise_um = 0.5\n", "noise_um = 0.5\nsensor_directions = [[0.8, 0.0, -0.6], "
        "[-0.4, 0.69282032, -0.6], [-0.4, -0.69282032, -0.6]]\n", 1))
    r = capture(s, control="sim", laser=f"sim:seed={SEED}", output=tmp_path / "C", **FAST)
    assert r.complete and r.outcomes[0].accepted == N
    lines = journal_path(tmp_path / "C", RT).read_text().splitlines()
    first = next(json.loads(x) for x in lines if '"type":"accepted"' in x and
                 '"reading":1,' in x)
    n = np.array([[0.8, 0.0, -0.6], [-0.4, 0.69282032, -0.6], [-0.4, -0.69282032, -0.6]])
    got = _readings(tmp_path / "C")
    assert np.allclose(first["values"], n @ got[1], atol=1e-4)  # the sensors' own readings
    assert np.max(np.abs(got - _readings(captured[0]))) < TOL_UM
