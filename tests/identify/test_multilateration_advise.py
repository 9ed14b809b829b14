"""Advice for multilateration designs: plain-word notes and the layout comparison."""

from __future__ import annotations

import numpy as np
from identify_helpers import TRAVEL

from volcal.identify import IdentifyOptions
from volcal.identify.multilateration import compare_layouts, design_notes, layout_messages
from volcal.plan.multilateration import default_stations, multilateration_tests
from volcal.session.format import Session


def _session(stations=None, offsets=((0, 0, 0), (100, 100, 0)), grid=(4, 3, 3)):
    return Session("trk", "XYFZ", TRAVEL,
                   multilateration_tests(TRAVEL, grid, stations, offsets))


def test_notes_name_coplanar_stations_and_missing_offsets():
    st = default_stations(TRAVEL)
    flat = st.copy()
    flat[:, 2] = -300.0
    text = " ".join(design_notes(_session(flat, offsets=((0, 0, 0),))))
    assert "one plane" in text
    assert "one tool offset" in text
    assert design_notes(_session(offsets=((0, 0, 0), (100, 0, 0), (0, 0, -100)))) == []
    text2 = " ".join(design_notes(_session(offsets=((0, 0, -100), (0, 0, -200)))))
    assert "roll" in text2 and "one line" in text2


def test_layout_comparison_more_data_lower_uncertainty():
    rows = compare_layouts(_session(), IdentifyOptions())
    by = {r["design"]: r for r in rows}
    base = by["as planned"]
    assert base["stations"] == 4 and base["offsets"] == 2 and base["points"] == 36
    assert by["3 stations"]["u_max_um"] > base["u_max_um"] > by["5 stations"]["u_max_um"]
    assert by["1 tool offset(s)"]["u_max_um"] > base["u_max_um"]
    # machine time: 8 measurements x (36 points x 4 s + the serpentine at 2000 mm/min)
    q = _session().measurements[0].positions
    path = np.linalg.norm(np.diff(q, axis=0), axis=1).sum()
    assert abs(base["machine_time_h"] * 3600 - 8 * (36 * 4.0 + path / 2000 * 60)) < 1e-6
    text = "\n".join(layout_messages(rows))
    assert "Proposal" in text or "good compromise" in text
