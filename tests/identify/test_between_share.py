"""The share of the volumetric uncertainty between the readings
(volcal.identify.between_share): what ``volcal identify`` prints and the report states.

Checked against a second computation (two predictions, with and without the part, where
the share computes the part through the Jacobian), against the design (readings at half
the spacing leave about an eighth of the part's variance), through both faces, and the
same for a session in memory and read back from its folder (the positions a file rounds
touch the same nodes).
"""

from __future__ import annotations

import sys
from types import SimpleNamespace

import numpy as np
import pytest

from volcal import Calibration
from volcal.identify import EstimatorSettings
from volcal.identify.between_share import between_share, part_grid, share_grid
from volcal.model.names import COMPONENT_NAMES
from volcal.standards.volumetric import work_zone_grid

TRAVEL = [[0, 1500], [0, 400], [0, 300]]
TESTS = ["diagonal", "linear", "step-diagonal"]


@pytest.fixture(scope="module")
def fits():
    """One virtual machine measured at 3 and at 6 increments."""
    out = {}
    for steps in (3, 6):
        c = Calibration.plan(TRAVEL, steps=steps, runs=2, tests=TESTS, name="SHARE")
        out[steps] = c.simulate(seed=7)
        out[steps].identify()
    return out


def test_share_is_the_prediction_with_and_without_the_part(fits):
    """``u_um`` is ``predict``'s largest u over the volumetric indices' grid with the whole
    noise part (the part between the readings among its columns), ``u_without_um`` the
    same model's without it, and ``between_um`` the largest ``sqrt(u^2 - u_without^2)``
    over that grid with its midpoints (or over the points given): the share computes the
    part through the Jacobian (one prediction), this test through two predictions."""
    import copy

    r = fits[3].result
    bare = copy.copy(r)
    bare.between_factor = None
    share = between_share(r)
    q = share_grid(r)
    np.testing.assert_array_equal(q, work_zone_grid(TRAVEL))  # the indices' grid
    assert share.points == q.shape[0] == 11**3 and "11 x 11 x 11 grid" in share.describe()
    assert "21 x 21 x 21" in share.describe()
    u, u0 = (m.predict(q, systematic=False)[1] for m in (r, bare))
    assert share.u_um == pytest.approx(u.max(), rel=1e-9)
    assert share.u_without_um == pytest.approx(u0.max(), rel=1e-9)
    assert share.nodes == r.between_factor.shape[1] > 0
    assert share.u_without_um < share.u_um
    qp = part_grid(np.array(TRAVEL, dtype=float))
    np.testing.assert_array_equal(qp, work_zone_grid(TRAVEL, 21))
    u, u0 = (m.predict(qp, systematic=False)[1] for m in (r, bare))
    assert share.between_um == pytest.approx(np.sqrt(u**2 - u0**2).max(), rel=1e-6)
    given = between_share(r, q)  # points given: every figure over them
    assert given.part_points == given.points == 11**3 and "midpoints" not in given.describe()
    assert share.part_points == 21**3
    assert given.between_um == pytest.approx(
        np.sqrt(np.maximum(r.predict(q, systematic=False)[1] ** 2
                           - bare.predict(q, systematic=False)[1] ** 2, 0)).max(), rel=1e-6)


def test_ten_increments_put_the_indices_grid_on_the_readings():
    """10 increments of each travel: the volumetric indices' 11 points per axis are the
    readings, where the part between the readings is zero, and the share over that grid
    alone said "up to 0.000 um" (session 15); over the grid with its midpoints (the nodes
    between the readings) the part is there (measured 0.188 um on this 3000 mm machine)."""
    import copy

    c = Calibration.plan([[0, 3000], [0, 800], [0, 600]], steps=10, runs=2, tests=TESTS)
    c.simulate(seed=7)
    r = c.identify()
    share = between_share(r)
    bare = copy.copy(r)
    bare.between_factor = None
    q = share_grid(r)
    u, u0 = (m.predict(q, systematic=False)[1] for m in (r, bare))
    assert np.sqrt(np.maximum(u**2 - u0**2, 0)).max() < 1e-6  # on the readings: none
    assert share.between_um > 0.05, share


def test_advise_forecasts_the_part_before_measuring(fits, tmp_path, monkeypatch, capsys):
    """``volcal advise`` on the planned session (no readings): the part between the readings
    with a typical machine's prior, on the identification's node grid, within a factor 2
    of what the identification of the simulated machine found (measured 2.49 / 1.01 um
    forecast, 2.23 / 0.85 um found at 3 / 6 increments, session 16), falling as the found
    part does; the sentence in the messages and ``between_readings`` in the JSON (null
    with the part off)."""
    import json

    from volcal.cli import main

    found = {s: between_share(fits[s].result).between_um for s in (3, 6)}
    fore = {}
    for steps in (3, 6):
        c = Calibration.plan(TRAVEL, steps=steps, runs=2, tests=TESTS, name="SHARE")
        rep = c.advise()  # the identifiability report, its forecast as .between
        f = rep.between
        assert f is not None and f.points == 21**3
        assert any(m == f.describe() for m in rep.messages)
        fore[steps] = f.between_um
        assert 0.5 <= fore[steps] / found[steps] <= 2.0, (fore, found)
    assert fore[6] / fore[3] == pytest.approx(found[6] / found[3], rel=0.3)
    c.save(tmp_path / "p")
    monkeypatch.setattr(sys, "argv", ["volcal", "advise", str(tmp_path / "p"), "--json"])
    with pytest.raises(SystemExit) as e:
        main()
    assert not e.value.code
    doc = json.loads(capsys.readouterr().out)
    assert doc["between_readings"]["between_um"] == pytest.approx(fore[6], rel=1e-9)
    from volcal.steps.advise import advise

    off = advise(tmp_path / "p", settings=EstimatorSettings(between_readings_factor=0.0))
    assert off.report.between is None and off.to_dict()["between_readings"] is None


def test_half_the_spacing_leaves_about_an_eighth(fits):
    """3 -> 6 increments: the part's largest variance falls to 1/16-1/4 of itself
    (measured 0.145: 2.23 -> 0.85 um over the grid with its midpoints, 0.105 over the
    indices' grid alone; the cube of the spacing would give 1/8)."""
    b3, b6 = (between_share(fits[s].result).between_um for s in (3, 6))
    assert 1 / 16 <= (b6 / b3) ** 2 <= 1 / 4, (b3, b6)


def test_none_without_the_part(fits):
    """Nothing to share without the part (factor 0) or for minimum norm."""
    c = fits[3]
    kept = c.result, c.evaluation  # the shared fit, put back (not identified again)
    try:
        assert between_share(c.identify(settings=EstimatorSettings(
            between_readings_factor=0.0))) is None
        assert between_share(c.identify(prior="none")) is None
    finally:
        c.result, c.evaluation = kept


def test_both_faces_say_it(fits, tmp_path, monkeypatch, capsys):
    """``volcal identify`` prints the sentence; the report's uncertainty section states it
    with the same numbers (one function, one grid)."""
    from volcal.cli import main
    from volcal.report.uncertainty import uncertainty_section

    fits[3].save(tmp_path / "s")
    monkeypatch.setattr(sys, "argv", ["volcal", "identify", str(tmp_path / "s"), "-o",
                                      str(tmp_path / "m.json")])
    with pytest.raises(SystemExit) as e:
        main()
    assert not e.value.code
    out = capsys.readouterr().out
    share = between_share(fits[3].result)
    line = next(x for x in out.splitlines() if x.startswith("between the readings: "))
    assert line == "between the readings: " + share.describe()  # the folder's = memory's
    assert f"{share.between_um:.3f} um" in line
    sec = uncertainty_section(SimpleNamespace(result=fits[3].result, volumetric=None))
    assert "Its share: the " + share.describe() + "." in sec.paragraphs


def test_functions_no_reading_moves_are_not_between_the_readings():
    """X's linear tests alone (three lines at Abbe offsets): they move EXX and, through
    the offsets, X's pitch and yaw EBX, ECX; the other 15 functions are not measured at
    all (the identifiability report says so), their nodes are not "between the readings",
    and denser readings would not change them. Forecast and share count only the unread
    nodes of those three functions (session 16 counted every node of the unmeasured
    functions too: the forecast said 28.25 um for this plan, 0.89 um now). The messages
    say why Y's and Z's functions are undetermined: no test moves those axes (all twelve:
    session 16 left out the four straightnesses, which have no free node on the analysis'
    grid, Y and Z each read at their two ends only)."""
    c = Calibration.plan([[0, 800], [0, 600], [0, 500]], steps=10, runs=2,
                         tests=["linear:x"], name="LINX")
    rep = c.advise()
    f = rep.between
    said = {m.split()[0]: m for m in rep.messages if "is not determined" in m}
    for axis in "YZ":  # all 12 of Y and Z, why: the axis is never moved (the
        # straightnesses, held at both ends of the two positions read, were left out);
        # one line per axis (session 18; one per function before)
        line = [m for m in rep.messages if m.startswith(f"No test here moves the {axis} axis")]
        names = [n for n in COMPONENT_NAMES if n[2] == axis]
        assert len(line) == 1 and f"errors: {', '.join(names)} are not determined" in line[0]
        assert all(rep.determined_fraction[n] == 0.0 and n not in said for n in names)
    assert "No test here moves" not in said["EAX"] and "lever arms" in said["EAX"]
    assert not any(m.startswith("Roll:") and "EBY" in m for m in rep.messages)
    # the suggested tests at the finest axis' increments (session 18: "--steps 2", the
    # two ends of the unmoved Y and Z), as for the linear tests of all three axes
    add = next(m for m in rep.messages if m.startswith("To add it:"))
    steps = int(add.split("--steps ")[1].split()[0])
    assert steps >= 10, add
    c.simulate(seed=5)
    r = c.identify()
    free = np.asarray(r.free)
    moved = np.isin(free, np.concatenate([r.layout.indices(0, k) for k in (0, 4, 5)]))
    part = np.sum(np.asarray(r.between_factor) ** 2, axis=1) > 0
    unread_x = moved & part
    assert not part[~moved].any()  # the 15 functions no reading moves: their prior alone
    share = between_share(r)
    assert f is not None and share is not None
    assert f.nodes == share.nodes == int(unread_x.sum()) > 0, (f, share)
    assert f.between_um < 2.0, f
    assert share.between_um < 2.0 and share.u_um > 10.0, share  # the unmeasured: the rest


def test_errors_of_a_kind_no_reading_sees_are_one_line():
    """The linear tests of all three axes see no straightness, roll or squareness: one
    line per kind lists them (session 18: twelve lines, one per function, each "only 0 %
    of its prior uncertainty is removed"); the determined fractions stay per function."""
    rep = Calibration.plan([[0, 800], [0, 600], [0, 500]], steps=10, runs=2,
                           tests=["linear"], name="LIN").advise()
    lines = {m.split(" errors ")[0]: m for m in rep.messages if m.startswith("The ")}
    for what, names in (("straightness", "EYX, EZX, EXY, EZY, EXZ, EYZ"),
                        ("roll", "EAX, EBY, ECZ"), ("squareness", "EC0Y, EB0Z, EA0Z")):
        assert lines[f"The {what}"].startswith(
            f"The {what} errors {names} are not determined by the data (none of their "
            "prior uncertainty removed): "), lines
        assert all(rep.determined_fraction[n] < 0.005 for n in names.split(", "))
    assert not any("is not determined" in m for m in rep.messages), rep.messages
    assert "Roll: EAX, EBY, ECZ not measured" in " ".join(rep.messages)
