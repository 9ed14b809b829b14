"""ISO 230-1 straightness and squareness against a published worked example.

Source
------
Hewlett-Packard, *Model 5528A Laser Measurement System User's Guide* (the predecessor of
the Agilent/Keysight 5529A/5530 kits), Section 21 "Straightness and Squareness
Considerations" (page footer "OCT 87"), pages 21-1 to 21-8: "Calculation of Slope"
(end-point fit, 21-1 to 21-3; least-squares fit, 21-3 to 21-6), "Calculation of
Squareness" (21-6, 21-7), Figure 21-1 "Squareness" (21-8). Scanned pages with their text
layer: https://www.easymanua.ls/hp/5528a/manual?p=308 to ``?p=315`` (21-3 is ``p=310``,
21-6 ``p=313``, 21-7 ``p=314``, 21-8 ``p=315``); the same scan is at
https://www.manualslib.com/manual/1497263/Hp-5528a.html?page=308.

The manual works one example through both reference lines, by hand, and prints every
intermediate number. Its data (``Y_LMS``, the laser display [um], at ``X`` [m]):

====  ==========================================  =============================================
      axis 1 (10 points, 0.1 m apart)             axis 2 (10 points, 0.05 m apart)
====  ==========================================  =============================================
X     0.0 0.1 0.2 ... 0.9 m                       0.0 0.05 0.1 ... 0.45 m
Y     -0.3 0.9 1.5 2.5 2.9 3.6 4.2 5.1 5.9 7.2   -0.5 -1.2 -2.5 -3.8 -4.0 -4.8 -5.9 -6.2 -7.4 -8.8
====  ==========================================  =============================================

Its published results (printed precision):

* end-point fit, axis 1 (21-3): ``m1 = 8.33 um/m``, ``Y_slope = 8.33 X - 0.3``,
  ``Y_true = Y_LMS - Y_slope`` = 0.0 0.4 0.1 0.3 -0.1 -0.3 -0.5 -0.4 -0.5 0.0 um;
* end-point fit, axis 2 (21-3): ``m2 = (-8.8 - (-0.5)) / 0.45 = -18.44 um/m``,
  ``Y_true`` = 0.0 0.22 -0.16 -0.53 0.19 0.31 0.13 0.76 0.48 0.0 um;
* least-squares fit, axis 2 (21-6), with the sums ``sum X = 2.25``, ``sum Y = -45.1``,
  ``sum X^2 = 0.7125``, ``sum XY = -13.74``: ``m2 = -17.42 um/m``, ``b = -0.591 um``,
  ``Y_true`` = 0.09 0.262 -0.167 -0.596 0.08 0.146 -0.083 0.488 0.159 -0.37 um;
* least-squares fit, axis 1 (table on 21-7): ``m1 = 7.65 um/m``;
* angles of misalignment ``theta = arctan(m) x 3600`` [arcsec] (21-7): end-point 1.7 and
  -3.8, least-squares 1.6 and -3.6;
* squareness = ``theta2 - theta1 + optical square error`` (21-7, Figure 21-1), with the
  square's error 0: **end-point fit -5.5 arcsec, least-squares fit -5.2 arcsec**.

Transcription notes (the scan's text layer drops and invents minus signs). Every
``Y_true`` above was checked against the manual's own definition ``Y_LMS - Y_slope`` with
its printed ``Y_slope`` rows (e.g. axis 2, X = 0.05 m: -1.2 - (-1.42) = +0.22); the
intercept's sign likewise (axis 2, X = 0: Y_true = -0.5 - b = 0.09, so b = -0.591). The
text layer of the 21-7 table reads "-3.6" in the end-point row of axis 2; the manual's
own rule gives arctan(-18.44e-6) x 3600 = -3.80 arcsec, and its printed squareness
-5.5 = -3.8 - 1.7 needs -3.8, so -3.8 is asserted. The least-squares line of axis 1 is on
page 21-5, which could not be retrieved: its slope is the one printed on 21-7 (7.65); its
straightness (range of the residuals) is hand-computed below, with the computation.

The straightness deviation of ISO 230-1 is the range of the residuals about the
reference line: the manual prints the residuals (``Y_true``), not their range, so the
range asserted is max - min of the printed row (axis 1 end-point 0.4 - (-0.5) = 0.9;
axis 2 end-point 0.76 - (-0.53) = 1.29; axis 2 least squares 0.488 - (-0.596) = 1.084).

Convention mapping
------------------
* Reference lines: the manual's "End Point Fit" (line through the first and the last
  reading) and "Least Squares Fit" are volcal's ``'end_point'`` and ``'least_squares'``.
  Neither is the minimum zone.
* Units: X [m] -> positions [mm] (x 1000); a slope in um/m is a slope in urad.
* Squareness: the manual's theta1, theta2 are the angles of the two machine axes from
  their optical axes, in one rotational sense (its sign-convention procedure, 21-8 ff.,
  makes the readings so), and the angle between axis 1 and axis 2 is
  ``90 deg + theta2 - theta1 + optical square error`` (Figure 21-1). volcal reads line 1
  along ``u`` with deviations along ``+v`` (slope ``s1 = dv/du``) and line 2 along ``v``
  with deviations along ``+u`` (``s2 = du/dv``), angle between ``+u`` and ``+v`` =
  ``90 deg - (s1 + s2) + square_deviation_urad``. With ``u`` = axis 1 and ``v`` = axis 2
  turned 90 deg counter-clockwise from it, a counter-clockwise tilt theta is
  ``s1 = +theta1`` on line 1 and ``s2 = -theta2`` on line 2 (a CCW-turned ``+v`` leans
  toward ``-u``). So volcal's line 1 is the manual's axis 1 as printed and volcal's line 2
  is the manual's axis 2 with its sign changed; then ``-(s1 + s2) = theta2 - theta1``
  exactly, and the manual's "optical square error" is ``square_deviation_urad`` (both are
  added to the angle). Here ``u, v`` = X, Y, so the squareness is EC0Y = S_xy.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from volcal.standards.straightness import (
    squareness_from_lines,
    squareness_from_slopes,
    straightness,
)
from volcal_cli_helpers import run_volcal

# --- the manual's data (HP 5528A User's Guide, 21-3, 21-4, 21-6) ---------------------------
X1_M = np.round(np.arange(10) * 0.1, 10)
Y1_UM = np.array([-0.3, 0.9, 1.5, 2.5, 2.9, 3.6, 4.2, 5.1, 5.9, 7.2])
X2_M = np.round(np.arange(10) * 0.05, 10)
Y2_UM = np.array([-0.5, -1.2, -2.5, -3.8, -4.0, -4.8, -5.9, -6.2, -7.4, -8.8])

# --- its printed results (least squares: with the decimals printed) ---------------
EP1_YTRUE = ([0.0, 0.4, 0.1, 0.3, -0.1, -0.3, -0.5, -0.4, -0.5, 0.0], None)
EP2_YTRUE = ([0.0, 0.22, -0.16, -0.53, 0.19, 0.31, 0.13, 0.76, 0.48, 0.0], None)
LS2_YTRUE = ([0.09, 0.262, -0.167, -0.596, 0.08, 0.146, -0.083, 0.488, 0.159, -0.37],
             (2, 3, 3, 3, 2, 3, 3, 3, 3, 2))
SLOPE_UM_PER_M = {("end_point", 1): 8.33, ("end_point", 2): -18.44,
                  ("least_squares", 1): 7.65, ("least_squares", 2): -17.42}
THETA_ARCSEC = {("end_point", 1): 1.7, ("end_point", 2): -3.8,
                ("least_squares", 1): 1.6, ("least_squares", 2): -3.6}
SQUARENESS_ARCSEC = {"end_point": -5.5, "least_squares": -5.2}

URAD_PER_ARCSEC = math.pi / 180 / 3600 * 1e6  # 4.8481 urad


def _half_unit(decimals: int) -> float:
    """Half a unit of the last printed digit: the most a printed number was rounded by."""
    return 0.5 * 10.0 ** -decimals


def _arcsec(slope_urad: float) -> float:
    """The manual's angle of misalignment: arctan(m) x 3600 with m dimensionless."""
    return math.degrees(math.atan(slope_urad * 1e-6)) * 3600


def _line(axis: int):
    return (X1_M * 1e3, Y1_UM) if axis == 1 else (X2_M * 1e3, Y2_UM)


@pytest.mark.parametrize("ref", ["end_point", "least_squares"])
@pytest.mark.parametrize("axis", [1, 2])
def test_slopes_and_angles_of_misalignment(ref, axis):
    """Slope [um/m = urad] to the printed 0.01 um/m; the angle to the printed 0.1 arcsec."""
    r = straightness(*_line(axis), reference=ref)
    assert r.reference == ref
    assert r.slope_urad == pytest.approx(SLOPE_UM_PER_M[ref, axis], abs=_half_unit(2))
    assert _arcsec(r.slope_urad) == pytest.approx(THETA_ARCSEC[ref, axis], abs=_half_unit(1))


@pytest.mark.parametrize("ref, axis, printed, line_rounding", [
    ("end_point", 1, EP1_YTRUE, 0.05),
    ("end_point", 2, EP2_YTRUE, 0.005),
    ("least_squares", 2, LS2_YTRUE, 0.001)])
def test_residuals_and_straightness_against_the_printed_rows(ref, axis, printed,
                                                             line_rounding):
    """The residuals ``Y_true`` row by row, and the straightness deviation = their range.

    How far a printed residual can be from the exact one: the end-point rows subtract a
    ``Y_slope`` printed to 0.1 um (axis 1: -0.3 0.5 1.4 2.2 3.0 3.9 4.7 5.5 6.4 7.2) or
    0.01 um (axis 2) from readings of 0.1 um resolution, exactly, so by half that digit
    (0.05, 0.005 um). The least-squares row uses the rounded line m = -17.42, b = -0.591
    (at most 0.0018 um/m x 0.45 m + 0.0001 um < 0.001 um off) and is printed to 2 or 3
    decimals: half its last digit more."""
    values, decimals = printed
    decimals = decimals if isinstance(decimals, tuple) else (None,) * len(values)
    r = straightness(*_line(axis), reference=ref)
    tols = [line_rounding + (_half_unit(d) if d is not None else 0.0) for d in decimals]
    for i, (got, want, tol) in enumerate(zip(r.residuals_um, values, tols, strict=True)):
        assert got == pytest.approx(want, abs=tol), i
    # ISO 230-1 straightness deviation: range of the residuals (of the printed row:
    # axis 1 EP 0.4 - (-0.5) = 0.9; axis 2 EP 0.76 - (-0.53) = 1.29; LS 0.488 - (-0.596))
    want = max(values) - min(values)
    i_max, i_min = int(np.argmax(values)), int(np.argmin(values))
    assert r.straightness_um == pytest.approx(want, abs=tols[i_max] + tols[i_min])


def test_least_squares_line_of_axis_2_matches_the_printed_sums():
    """21-6: m2 = (sum X sum Y - n sum XY) / ((sum X)^2 - n sum X^2)
    = ((2.25)(-45.1) - (10)(-13.74)) / ((2.25)^2 - (10)(0.7125)) = -17.42 um/m and
    b = (sum X sum XY - sum Y sum X^2) / ((sum X)^2 - n sum X^2) = -0.591 um."""
    assert X2_M.sum() == pytest.approx(2.25) and Y2_UM.sum() == pytest.approx(-45.1)
    assert (X2_M ** 2).sum() == pytest.approx(0.7125)
    assert (X2_M * Y2_UM).sum() == pytest.approx(-13.74)
    r = straightness(X2_M * 1e3, Y2_UM, "least_squares")
    assert r.slope_urad == pytest.approx(-17.42, abs=_half_unit(2))
    assert r.intercept_um == pytest.approx(-0.591, abs=_half_unit(3))


def test_least_squares_straightness_of_axis_1_by_hand():
    """Page 21-5 could not be retrieved; the slope 7.65 is printed on 21-7, the rest by hand.

    Sums: n = 10, sum X = 4.5 m, sum Y = 33.5 um, sum X^2 = 2.85 m^2, sum XY = 21.39 um m.
    m1 = (4.5 x 33.5 - 10 x 21.39) / (4.5^2 - 10 x 2.85) = -63.15 / -8.25 = 7.654545 um/m;
    b1 = (4.5 x 21.39 - 33.5 x 2.85) / -8.25 = (96.255 - 95.475) / -8.25 = -0.094545 um.
    Residuals Y - (b1 + m1 X): at X = 0: -0.3 + 0.094545 = -0.205455; the largest is at
    X = 0.9 m: 7.2 - (-0.094545 + 6.889091) = 0.405455; the smallest at X = 0.6 m:
    4.2 - (-0.094545 + 4.592727) = -0.298182. Straightness 0.405455 + 0.298182 = 0.703636 um.
    """
    r = straightness(X1_M * 1e3, Y1_UM, "least_squares")
    assert r.slope_urad == pytest.approx(63.15 / 8.25, abs=1e-9)
    assert r.intercept_um == pytest.approx(-0.78 / 8.25, abs=1e-9)
    assert r.residuals_um[0] == pytest.approx(-0.205455, abs=1e-6)
    assert r.straightness_um == pytest.approx(0.405455 + 0.298182, abs=2e-6)
    assert int(np.argmax(r.residuals_um)) == 9 and int(np.argmin(r.residuals_um)) == 6


@pytest.mark.parametrize("ref", ["end_point", "least_squares"])
def test_squareness_from_the_two_slopes(ref):
    """Squareness = theta2 - theta1 (square error 0): -5.5 arcsec (end-point), -5.2 arcsec
    (least squares); volcal's line 2 is the manual's axis 2 with its sign changed."""
    s1 = straightness(X1_M * 1e3, Y1_UM, ref).slope_urad
    s2 = straightness(X2_M * 1e3, -Y2_UM, ref).slope_urad
    got = squareness_from_slopes(s1, s2)
    assert got / URAD_PER_ARCSEC == pytest.approx(SQUARENESS_ARCSEC[ref], abs=_half_unit(1))
    # and the manual's rule itself, from its arctan angles: the same to 1e-6 arcsec
    theta1 = _arcsec(straightness(X1_M * 1e3, Y1_UM, ref).slope_urad)
    theta2 = _arcsec(straightness(X2_M * 1e3, Y2_UM, ref).slope_urad)
    assert got / URAD_PER_ARCSEC == pytest.approx(theta2 - theta1, abs=1e-6)
    if ref == "least_squares":
        assert squareness_from_lines(X1_M * 1e3, Y1_UM, X2_M * 1e3, -Y2_UM) == got


def _write_session(folder, square_deviation_urad: float) -> None:
    """The example as a session folder in the format of docs/formats.md: axis 1 along X,
    read along +Y (``str-xy``), axis 2 along Y, read along +X (``str-yx``), one optical
    square (reference group ``xy``; ``str-xy`` first, so read straight on). Readings count
    from the first row (docs/formats.md), so the first reading (-0.3, -0.5 um) is taken
    off each line: a constant, which moves neither a slope nor a range."""
    folder.mkdir()
    (folder / "session.toml").write_text(f"""format = "volcal-session/1"

[machine]
name = "HP 5528A User's Guide, section 21 example"
chain = "XYFZ"

[machine.travel_mm]
x = [0, 1000]
y = [0, 500]
z = [0, 400]

[references.xy]
square_deviation_urad = {square_deviation_urad!r}
u_square_urad = 0.5

[[measurements]]
id = "str-xy"
kind = "straightness"
axis = "x"
error_direction = "y"
reference = "xy"
target = "straightness_optics"
file = "str-xy.csv"

[[measurements]]
id = "str-yx"
kind = "straightness"
axis = "y"
error_direction = "x"
reference = "xy"
target = "straightness_optics"
file = "str-yx.csv"
""", encoding="utf-8")
    rows = [f"{x * 1e3:g},0,0,{y - Y1_UM[0]:.1f}" for x, y in zip(X1_M, Y1_UM, strict=True)]
    (folder / "str-xy.csv").write_text("x_mm,y_mm,z_mm,deviation_um\n" + "\n".join(rows)
                                       + "\n", encoding="utf-8")
    # the manual's axis 2 with its sign changed (module docstring, "Convention mapping")
    rows = [f"0,{x * 1e3:g},0,{0.0 - (y - Y2_UM[0]):.1f}"
            for x, y in zip(X2_M, Y2_UM, strict=True)]
    (folder / "str-yx.csv").write_text("x_mm,y_mm,z_mm,deviation_um\n" + "\n".join(rows)
                                       + "\n", encoding="utf-8")


@pytest.mark.parametrize("square_arcsec", [0.0, 1.0])
def test_cli_evaluate_optics_on_the_published_example(tmp_path, monkeypatch, capsys,
                                                      square_arcsec):
    """``volcal evaluate optics --json`` on the example written as a session folder.

    With the square's error 0 (the manual's case) EC0Y is -5.5 arcsec (end-point) and
    -5.2 arcsec (least squares). With a square 1 arcsec over 90 deg the manual's rule
    (squareness = theta2 - theta1 + optical square error, 21-7) adds 1 arcsec: -4.5 and
    -4.2 arcsec (this second case applies the published rule to a value of our own)."""
    folder = tmp_path / "hp5528a"
    _write_session(folder, square_arcsec * URAD_PER_ARCSEC)
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(folder), "--json")
    assert code == 0, out
    ev = json.loads(out)
    for mid, axis in (("str-xy", 1), ("str-yx", 2)):
        line = ev["straightness"][mid]
        sign = 1.0 if axis == 1 else -1.0  # volcal's line 2 = the manual's axis 2 negated
        for ref in ("end_point", "least_squares"):
            assert sign * line[ref]["slope_urad"] == pytest.approx(
                SLOPE_UM_PER_M[ref, axis], abs=_half_unit(2))
    # straightness = range of the printed residual rows (see the module docstring)
    assert ev["straightness"]["str-xy"]["end_point"]["straightness_um"] == pytest.approx(
        0.9, abs=0.1)
    assert ev["straightness"]["str-yx"]["end_point"]["straightness_um"] == pytest.approx(
        1.29, abs=0.01)
    assert ev["straightness"]["str-yx"]["least_squares"]["straightness_um"] == pytest.approx(
        1.084, abs=0.003)
    (sq,) = ev["squareness"]
    assert sq["name"] == "EC0Y" and sq["axes"] == "xy" and sq["lines"] == ["str-xy", "str-yx"]
    assert sq["square_deviation_urad"] == pytest.approx(square_arcsec * URAD_PER_ARCSEC)
    for ref in ("end_point", "least_squares"):
        want = SQUARENESS_ARCSEC[ref] + square_arcsec
        assert sq[ref]["EC0Y"] / URAD_PER_ARCSEC == pytest.approx(want, abs=_half_unit(1))
        assert sq[ref]["angle_minus_90_urad"] == sq[ref]["EC0Y"]  # EC0Y = S_xy

    # the table output names both figures
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(folder))
    assert code == 0
    ep = ev["squareness"][0]["end_point"]["EC0Y"]
    ls = ev["squareness"][0]["least_squares"]["EC0Y"]
    assert f"EC0Y = {ls:.2f} urad from the least-squares" in " ".join(out.split())
    assert f"{ep:.2f} urad from the end-point" in " ".join(out.split())
