"""The multilateration section of the report: stations table, residuals per station, layout."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from volcal.plan.multilateration import multilateration_tests
from volcal.report.multilateration import multilateration_section
from volcal.report.sections import ReportInputs
from volcal.session.format import Session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def test_section_tables_from_the_fit():
    ms = multilateration_tests(TRAVEL, (3, 3, 2))
    s = Session("m", "XYFZ", TRAVEL, ms)
    from volcal.measure.multilateration import station_key

    keys = list(dict.fromkeys(station_key(m) for m in ms))
    stations = [{"station": k, "nominal_mm": m.meta["station_mm"],
                 "fitted_mm": list(np.add(m.meta["station_mm"], [3.0, 4.0, 0.0])),
                 "u_um": [0.5, 0.6, 0.7], "measurements": []}
                for k, m in zip(keys, ms[:4], strict=True)]
    res = {m.id: np.full(m.n, 0.2 if m.id.startswith("trk-s1") else -0.1) for m in ms}
    res["trk-s1-t1"][0] = 1.0
    r = SimpleNamespace(fit={"multilateration": {"stations": stations, "converged": True}},
                        residuals=res)
    sec = multilateration_section(ReportInputs(s, r))
    st, rs = sec.tables
    assert st.rows[0][0] == "S1" and st.rows[0][4] == "5.000"  # a 3-4-5 shift [mm]
    assert st.rows[2][3] == "0.50, 0.60, 0.70"
    n1 = 2 * ms[0].n
    rms1 = np.sqrt((1.0 + (n1 - 1) * 0.04) / n1)
    assert rs.rows[0][1] == str(n1) and rs.rows[0][2] == f"{rms1:.3f}"
    assert rs.rows[0][3] == "1.000" and rs.rows[1][2] == "0.100"
    assert len(sec.figures) == 1


def test_no_section_without_multilateration():
    ms = multilateration_tests(TRAVEL, (3, 3, 2))
    s = Session("m", "XYFZ", TRAVEL, [])
    assert multilateration_section(ReportInputs(s)) is None
    assert ms  # the plan itself is fine
