"""``volcal advise`` ranks direct optics as ``plan --add`` additions and prints their command.

The command printed for the best direct optic, run as printed, adds exactly the lines the
advice evaluated; after ``simulate`` and ``identify`` the roll it names is determined.
"""

from __future__ import annotations

import re
import shlex

import numpy as np
from typer.testing import CliRunner

from volcal.cli import app
from volcal.identify import identify
from volcal.plan.additions import candidate_additions
from volcal.session.format import read_session

runner = CliRunner()


def _ok(args):
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    return r.output


def _err(args) -> str:
    from volcal.errors import VolcalInputError

    r = runner.invoke(app, args)
    assert r.exit_code != 0
    assert isinstance(r.exception, VolcalInputError), r.output
    return " ".join(str(r.exception).split())


def test_advise_level_command_adds_it_and_determines_roll(tmp_path):
    s = tmp_path / "S"
    _ok(["plan", "-o", str(s), "--steps", "6", "--runs", "1"])  # the seeds' test set
    before = read_session(s, require_deviation=False)
    out = _ok(["advise", str(s)])
    flat = " ".join(out.split())
    assert "EAX (roll of X) is not determined" in flat  # the seeds' weak spot
    assert "Best direct optic: a level on X" in flat
    m = re.search(r"To add the direct optic: (volcal plan --add \S+ --tests direct:level-x"
                  r"(?: --steps \d+)?)", flat)
    assert m, flat
    argv = shlex.split(m.group(1))[1:]
    assert argv[2] == str(s)
    out = _ok(argv)
    assert "added 1 measurements" in out and "lev-xa" in out
    after = read_session(s, require_deviation=False)
    new = [*after.measurements, *after.unmeasured][-1]
    assert (new.id, new.kind, new.target, new.meta["axis"], new.meta["rotation"]) == \
        ("lev-xa", "angular", "level", "x", "a")
    # what advise evaluated is what was added: same poses as the candidate it planned
    steps = int(argv[argv.index("--steps") + 1]) if "--steps" in argv else 10
    cand = next(a for a in candidate_additions(before.travel) if a.tests == ("direct:level-x",))
    planned = cand.plan(before.travel, before.chain, steps)
    assert len(planned) == 1
    np.testing.assert_allclose(new.positions, planned[0].positions)
    _ok(["simulate", str(s), "--seed", "5"])
    res = identify(read_session(s))
    frac = res.report.determined_fraction["EAX"]
    assert frac > 0.9, frac


def test_plan_add_direct_selectors_and_fresh_reference(tmp_path):
    s = tmp_path / "S"
    _ok(["plan", "-o", str(s), "--steps", "4", "--runs", "1", "--tests", "linear"])
    _ok(["plan", "--add", str(s), "--tests", "direct:roll-z", "--steps", "4", "--runs", "1"])
    _ok(["plan", "--add", str(s), "--tests", "direct:roll-z", "--steps", "4", "--runs", "1"])
    got = read_session(s, require_deviation=False)
    refs = {m.id: m.meta["reference"] for m in [*got.measurements, *got.unmeasured]
            if m.kind == "straightness"}
    # two set-ups of the reference optic: never one group across two --add runs
    assert refs == {"str-zx": "z-roll", "str-zx-roll": "z-roll",
                    "str-zx-2": "z-roll-2", "str-zx-roll-2": "z-roll-2"}
    assert "a level reads the roll of a horizontal axis" in _err(
        ["plan", "--add", str(s), "--tests", "direct:level-z"])
    before = (s / "session.toml").read_text()
    assert "direct:level-x" in _err(["plan", "--add", str(s), "--tests", "direct:w"])
    assert (s / "session.toml").read_text() == before


def test_vertical_axis_of_the_session_is_used(tmp_path):
    s = tmp_path / "S"
    _ok(["plan", "-o", str(s), "--steps", "4", "--runs", "1", "--tests", "linear"])
    text = (s / "session.toml").read_text()
    text = text.replace("[machine]\n", '[machine]\nvertical_axis = "y"\n', 1)
    (s / "session.toml").write_text(text)
    assert 'vertical_axis = "y"' in text
    _ok(["plan", "--add", str(s), "--tests", "direct:level-z", "--steps", "4", "--runs", "1"])
    assert "level-y" in _err(["plan", "--add", str(s), "--tests", "direct:level-y"])
    labels = [a.tests for a in candidate_additions(read_session(s, require_deviation=False)
                                                   .travel, 1)]
    assert ("direct:level-z",) in labels and ("direct:roll-y",) in labels
    assert ("direct:level-y",) not in labels
