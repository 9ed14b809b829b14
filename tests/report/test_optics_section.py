"""The direct-optics section of the report: straightness, angular ranges, optical squares."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from optics_helpers import hand_budget, hand_session

from volcal.plan.planner import plan_session
from volcal.report.optics import optics_section
from volcal.report.sections import ReportInputs, build_report
from volcal.session.format import Session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def test_section_tables_by_hand():
    s = plan_session(TRAVEL, "XYFZ", 3, ("direct",), runs=1, iso_spacing=False,
                     linear_margin_mm=0.0)
    keep = {"str-xy", "str-yx", "lev-xa"}
    ms = [m for m in s.measurements if m.id in keep]
    for m in ms:
        m.columns = {}
        k = m.axis
        m.positions = m.positions[:4]
        m.positions[:, k] = [0.0, 100.0, 200.0, 300.0]
    by = {m.id: m for m in ms}
    xy, yx, lev = by["str-xy"], by["str-yx"], by["lev-xa"]
    xy.deviation = np.array([0.0, 2.0, 1.0, 3.0])  # end-point 2 um, least squares 1.8 um
    yx.deviation = np.array([0.0, 1.0, 2.0, 3.0])  # a straight line: slope 10 urad
    lev.deviation = np.array([0.0, -4.0, 2.5, 1.0])  # range 6.5 urad
    sess = Session("m", "XYFZ", TRAVEL, ms, references={"xy": {"square_deviation_urad": 1.0}})
    r = SimpleNamespace(residuals={"lev-xa": np.array([0.0, 3.0, -4.0, 0.0])})
    sec = optics_section(ReportInputs(sess, r))
    st, ang, sq = sec.tables
    assert st.rows[0][:6] == ["str-xy", "X", "Y", "300.0", "2.000", "1.800"]
    assert ang.rows[0][4] == "6.50" and ang.rows[0][5] == "2.500"  # sqrt(25/4)
    # EC0Y = -(s1 + s2) + delta: least squares -(8 + 10) + 1, end point -(10 + 10) + 1
    assert sq.rows[0][0] == "EC0Y" and sq.rows[0][4:] == ["-17.00", "-19.00"]
    assert optics_section(ReportInputs(Session("m", "XYFZ", TRAVEL, []), None)) is None
    ids = [x.id for x in build_report(ReportInputs(sess, None)).sections]
    assert "optics" in ids


def test_section_with_a_budget_has_u_by_hand():
    """The same lines with a budget (straightness 0.5 %, 0.3 um; level 1 %, 0.5 urad):
    U beside each value, the numbers of tests/standards/test_optics_uncertainty.py:
    end point 2 sqrt(0.2001) = 0.895, least squares 2 sqrt(0.162081) = 0.805 um,
    level range 2 sqrt(0.504225) = 1.42 urad; the square pair (str-xy slopes 10 / 8 urad,
    str-yx 10 urad, u_square 2.5 urad by default, one optic): least squares
    EC0Y = -17, |EC0Y - delta| = 18: u^2 = (18 x 0.005)^2 + 0.09 (|w1|^2 + |w2|^2) + 2.5^2
    with w = (-3, -1, 1, 3) urad/um, |w|^2 = 20 per line -> 2 sqrt(0.0081 + 3.6 + 6.25)
    = 6.28 urad."""
    sess = hand_session(name="m", u_square_urad=None)
    sec = optics_section(ReportInputs(sess, None, budget=hand_budget()))
    st, ang, sq = sec.tables
    assert st.columns[4:8] == ["end-point [µm]", "U [µm]", "least squares [µm]", "U [µm]"]
    assert st.rows[0][4:8] == ["2.000", "0.895", "1.800", "0.805"]
    assert ang.rows[0][4:6] == ["6.50", "1.42"]
    assert sq.rows[0][4:6] == ["-17.00", f"{2 * np.sqrt(0.0081 + 3.6 + 6.25):.2f}"]
    assert any("k = 2" in p for p in sec.paragraphs)
