"""Fuzzed session files given to ``volcal program``: a VolcalInputError or programs,
never a traceback, never a partial output folder."""

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from volcal.errors import VolcalInputError
from volcal.plan.planner import plan_session
from volcal.program import ProgramOptions, write_programs
from volcal.session.format import read_session, write_session

TRAVEL = np.array([[0.0, 300.0], [0.0, 200.0], [0.0, 100.0]])
SESSION = plan_session(TRAVEL, "XYFZ", 2, ["linear", "diagonal"], 1)


@st.composite
def damage(draw):
    """(file name, new text) with a few lines replaced, deleted or garbled."""
    name = draw(st.sampled_from(["session.toml", SESSION.measurements[0].file,
                                 SESSION.measurements[-1].file]))
    return name, draw(st.lists(st.tuples(
        st.sampled_from(["replace", "delete", "insert", "truncate"]),
        st.integers(0, 200),
        st.one_of(st.text(max_size=20),
                  st.sampled_from(["x = [", "nan", "1e999", "-1e6", "kind = \"bogus\"", ",,,",
                                   "x_mm,y_mm", "target = 3", "[[measurements]]", "run", "+",
                                   "# note",
                                   "", "notes = \"(x) ; y\""]))),
        min_size=0, max_size=3))


def _apply(text: str, ops) -> str:
    lines = text.splitlines()
    for op, i, s in ops:
        j = i % (len(lines) + 1)
        if op == "replace" and lines:
            lines[j % len(lines)] = s
        elif op == "delete" and lines:
            del lines[j % len(lines)]
        elif op == "insert":
            lines.insert(j, s)
        elif op == "truncate":
            lines = lines[:j]
    return "\n".join(lines)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(dmg=damage(), dialect=st.sampled_from(["fanuc", "siemens", "heidenhain"]))
def test_fuzzed_sessions(dmg, dialect):
    name, ops = dmg
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        write_session(SESSION, d / "s")
        f = d / "s" / name
        try:
            f.write_text(_apply(f.read_text(), ops), encoding="utf-8")
        except UnicodeEncodeError:
            return
        out = d / "p"
        try:
            s = read_session(d / "s", require_deviation=False)
            write_programs(s, dialect, out, ProgramOptions())
        except VolcalInputError as exc:
            event("VolcalInputError")
            assert str(exc)
            assert not out.exists()
            assert [p.name for p in d.iterdir()] == ["s"]
            return
        event("programs written")
        assert sorted(p.suffix for p in out.iterdir()).count(".toml") == 1
        assert len(list(out.iterdir())) == len(s.measurements) + 1
