"""Fuzzed laser exports: a VolcalInputError or a valid session, never a traceback or a
half-written session."""

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from volcal.errors import VolcalInputError
from volcal.importer import import_csv, parse_mapping
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])

cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 1000).map(str),
    st.sampled_from(["", "+", "-", "up", "down", "fwd", "1,5", "1.0", "nan", "\u00b5", '"', "x"]),
    st.text(max_size=6),
)
header = st.lists(st.sampled_from(["T", "E", "R", "D", "Pos (mm)", "Err [um]", "t", "junk",
                                   "T (in)", "Run 1", "Run 2 +", "Run 2 -", "Run x"]),
                  min_size=1, max_size=5)


good_cell = {"T": st.floats(-100, 900).map(lambda v: f"{v:.3f}"),
             "E": st.floats(-50, 50).map(lambda v: f"{v:.2f}"),
             "R": st.integers(0, 3).map(str), "D": st.sampled_from(["+", "-", "up", "down"]),
             "t": st.floats(0, 1e4).map(lambda v: f"{v:.1f}")}


@st.composite
def exports(draw):
    delim = draw(st.sampled_from([",", ";", "\t"]))
    shape = draw(st.integers(0, 2))
    if shape == 2:  # a wide table: one column per run (and direction)
        head = ["T", *draw(st.sampled_from([["Run 1", "Run 2"], ["Run 1 +", "Run 1 -"],
                                             ["1 up", "1 down", "2 up", "2 down"]]))]
        rows = [[draw(good_cell["T"])] + [draw(st.one_of(good_cell["E"], cell)
                                               if draw(st.integers(0, 30)) == 0
                                               else good_cell["E"]) for _ in head[1:]]
                for _ in range(draw(st.integers(0, 6)))]
    elif shape == 1:  # well-formed columns, occasionally damaged cells
        head = ["T", "E", "R", "D", "t"]
        rows = [[draw(st.one_of(good_cell[h], cell) if draw(st.integers(0, 30)) == 0
                      else good_cell[h]) for h in head]
                for _ in range(draw(st.integers(0, 8)))]
    else:
        head = draw(header)
        rows = draw(st.lists(st.lists(cell, min_size=0, max_size=len(head) + 1), max_size=8))
    pre = draw(st.lists(st.text(max_size=10), max_size=2))
    lines = pre + [delim.join(head)] + [delim.join(r) for r in rows]
    raw = "\n".join(lines).encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        raw = raw.replace(b"\xc2\xb5", b"\xb5")  # Windows-1252 micro sign
    return raw


mappings = st.sampled_from([
    "target=T,deviation=E", "target=T,reading=R,direction=D", "target=Pos,deviation=Err",
    "target=T,deviation=E,run=R,direction=D", "target=T (in),deviation=E", "target=T,time=t,"
    "deviation=E", "target=T,reading=E,run=R", "target=T,deviation=Run*",
    "target=T,deviation=? *", "target=T,reading=Run*"])


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


FUZZ = os.environ.get("HYPOTHESIS_PROFILE") == "fuzz"
N_FILES = 10_000 if FUZZ else 150
"""Generated exports: a fixed 150 in ``make test``, 10^4 new ones in the slow run
(``HYPOTHESIS_PROFILE=fuzz``, about 4 minutes)."""


@settings(max_examples=N_FILES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(raw=exports(), mapping=mappings, units=st.sampled_from(["auto", "mm", "in", "um"]),
       existing=st.booleans())
def test_fuzzed_import_never_traceback_never_partial(raw, mapping, units, existing):
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        f = d / "export.csv"
        try:
            f.write_bytes(raw)
        except UnicodeEncodeError:
            return
        sess = d / "s"
        if existing:
            write_session(plan_session(TRAVEL, "XYFZ", 2, ["diagonal"], 1), sess)
        before = _snapshot(sess) if existing else None
        try:
            r = import_csv(f, parse_mapping(mapping), "X", [0, 0, 0], sess, "imp", units,
                           travel=TRAVEL)
        except VolcalInputError as exc:
            event("VolcalInputError")
            assert str(exc)
            if existing:
                assert _snapshot(sess) == before
            else:
                assert not sess.exists()
            assert not [p for p in d.iterdir() if p.name.startswith(".")]
            return
        event("imported")
        back = read_session(sess, require_deviation=False)
        m = back.get("imp")
        np.testing.assert_allclose(m.positions, r.measurement.positions, atol=5e-7)  # 1 nm CSV
        assert m.n >= 2 and np.all(np.isfinite(m.deviation))
        shutil.rmtree(sess)
