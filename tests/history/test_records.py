"""Records a plant can trust (issue 26, findings 2, 3, 6): a retried add is harmless,
"last" is the newest measurement, as-left only of the same machine measured before, no
store made by a typo, positions outside the travel refused, the model stored once, typed
DataFrames. Every test on SQLite and PostgreSQL (``store_url``)."""

from __future__ import annotations

import datetime as _dt
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal_cli_helpers import volcal_process

# the model's U drawn once per model in this process (tests/model_u_once.py)
pytestmark = pytest.mark.usefixtures("model_u_once")

TRAVEL = [[0, 800], [0, 600], [0, 500]]


def _calibrate(folder: Path, machine, seed: int, date: str, name: str, serial: str) -> Path:
    from volcal.flow import Calibration

    c = Calibration.plan(TRAVEL, steps=6, name=name)
    c.simulate(machine=machine, seed=seed)
    c.save(folder)
    toml = folder / "session.toml"
    text = toml.read_text().replace("[machine]\n", f'[machine]\nserial = "{serial}"\n', 1)
    toml.write_text(text + f"\n[calibration]\ndate = {date}\n")
    c.identify().to_json(folder / "model.json")
    return folder


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    """Machine A measured 2026-01-10 and 2026-07-10 (E_VXYZ differs), machine B 2026-03-01;
    ``a2same``: A's July readings and model again, dated the same day (another session
    file, so another calibration)."""
    from volcal.measure.virtual import random_machine

    tmp = tmp_path_factory.mktemp("records")
    base = random_machine(TRAVEL, "XYFZ", seed=7)
    grown = base.copy()
    grown.values[0][:, 0] += 0.010 * grown.nodes[0]          # X scale +10 um/m
    out = {"a1": _calibrate(tmp / "a1", base, 1, "2026-01-10", "VMC-A", "A-1"),
           "a2": _calibrate(tmp / "a2", grown, 2, "2026-07-10", "VMC-A", "A-1"),
           "b": _calibrate(tmp / "b", random_machine(TRAVEL, "XYFZ", seed=8), 3,
                           "2026-03-01", "VMC-B", "B-2")}
    shutil.copytree(out["a2"], tmp / "a2same")
    toml = tmp / "a2same" / "session.toml"
    toml.write_text(toml.read_text() + '\n# copied: the same day, another session file\n')
    out["a2same"] = tmp / "a2same"
    return out


def _volcal(*args: str):
    return volcal_process(*args, timeout=scaled_timeout(300))


def _add(h, s: Path, **kw):
    return h.add(s, s / "model.json", **kw)


# ------------------------------------------------------------------ 1. idempotent add
def test_a_retried_add_returns_the_stored_id(store_url, sessions):
    s = sessions["a1"]
    args = ("history", "add", str(s), "--model", str(s / "model.json"), "--db", store_url)
    first = _volcal(*args, "--create")
    assert first.returncode == 0 and first.stdout == "C000002\n", first.stderr
    again = _volcal(*args)
    assert again.returncode == 0, again.stderr
    assert again.stdout == "C000002\n"                     # as a fresh add prints it
    assert ("note: this session and model are stored already as C000002 (measured "
            "2026-01-10); nothing added (--supersedes ID corrects a record)") in again.stderr
    lst = json.loads(_volcal("history", "list", "--json", "--all", "--db", store_url).stdout)
    assert [x["id"] for x in lst] == ["M000001", "C000002"]
    # a correction of the same content is still appended
    from volcal.history.api import History

    with History(store_url) as h:
        fix = _add(h, s, supersedes="C000002")
        assert fix.id == "C000003" and not fix.already_stored
        assert _add(h, s).id == "C000003"                 # the current version
        with pytest.raises(VolcalInputError, match=r"^this session and model are stored "
                           r"already as C000003, not as-left: --supersedes C000003 "
                           r"--as-left-of C000002 corrects it$"):
            _add(h, s, as_left_of="C000002")
        assert len(h.list()) == 3 and h.verify()[0]
        other = sessions["a2"]                               # corrected by other content
        assert h.add(other, other / "model.json", supersedes="C000003").id == "C000004"
    again = _volcal(*args)
    assert again.returncode == 0 and again.stdout == "C000003\n", again.stderr
    assert ("note: this session and model are stored already as C000003 (measured "
            "2026-01-10, superseded by C000004); nothing added") in again.stderr


# ------------------------------------------------------- 2. ordered by date measured
def test_a_backfilled_older_record_is_not_the_last(store_url, sessions):
    from volcal.history.api import History
    from volcal.history.compare import previous_calibration
    from volcal.history.due import due
    from volcal.history.fleet import fleet_html
    from volcal.session.format import read_session

    with History(store_url) as h:
        july = _add(h, sessions["a2"])                      # C000002, measured 2026-07-10
        jan = _add(h, sessions["a1"])                       # C000003, back-filled
        assert (july.id, jan.id) == ("C000002", "C000003")
        assert [r.id for r in h.calibrations("VMC-A")] == ["C000003", "C000002"]
        assert list(h.trend("VMC-A", "V.E_VXYZ").id) == ["C000003", "C000002"]
        page = fleet_html(h, today=_dt.date(2026, 11, 1))
        ev = july.results["V.E_VXYZ"]
        assert "2026-07-10 (C000002)" in page and "2026-01-10 (C000003)" not in page
        shown = f"<td>{ev['value']:.2f}" + ("" if ev["U"] is None else f" ± {ev['U']:.2f}")
        assert shown + "</td>" in page                        # July's E_VXYZ
        assert ev["value"] != pytest.approx(jan.results["V.E_VXYZ"]["value"], abs=0.01)
        assert {r["last"] for r in due(h, _dt.date(2026, 11, 1))} == {"2026-07-10"}
        # the report's previous calibration of another session of 2026-07-10: July's
        s = read_session(sessions["a2same"])
        assert previous_calibration(h.store, s).id == "C000002"
    lst = json.loads(_volcal("history", "list", "--json", "--db", store_url).stdout)
    assert [(x["id"], x["date"]) for x in lst] == [("C000003", "2026-01-10"),
                                                   ("C000002", "2026-07-10")]


# ------------------------------------------------------------ 3. as-left-of checked
def test_as_left_of_must_be_the_same_machine_measured_before(store_url, sessions):
    from volcal.history.api import History

    with History(store_url) as h:
        _add(h, sessions["a2"])                              # C000002: A, 2026-07-10
        with pytest.raises(VolcalInputError) as exc:
            _add(h, sessions["b"], as_left_of="C000002")
        assert str(exc.value) == (
            "--as-left-of C000002: C000002 is a calibration of VMC-A (M000001) measured "
            "2026-07-10; this session is of VMC-B (not in the history yet), measured "
            "2026-03-01: an as-left calibration pairs with an as-found one of the same "
            "machine")
        with pytest.raises(VolcalInputError) as exc:
            _add(h, sessions["a1"], as_left_of="C000002")
        assert str(exc.value) == (
            "--as-left-of C000002: C000002 of VMC-A (M000001) was measured 2026-07-10, "
            "after this session (2026-01-10): the as-found calibration is measured before "
            "(or on the same date as) its as-left one")
        with pytest.raises(VolcalInputError) as exc:
            _add(h, sessions["a1"], as_left_of="M000001")
        assert str(exc.value) == ("--as-left-of M000001: M000001 is a machine record, not "
                                  "a calibration")
        assert [r.id for r in h.list()] == ["M000001", "C000002"]    # nothing appended
        b = _add(h, sessions["b"])                                    # M000003, C000004
        with pytest.raises(VolcalInputError) as exc:
            _add(h, sessions["a1"], as_left_of=b.id)
        assert str(exc.value) == (
            "--as-left-of C000004: C000004 is a calibration of VMC-B (M000003) measured "
            "2026-03-01; this session is of VMC-A (M000001), measured 2026-01-10: an "
            "as-left calibration pairs with an as-found one of the same machine")
        ok = _add(h, sessions["a2same"], as_left_of="C000002")        # the same day
        assert ok.as_left_of == "C000002" and ok.machine_id == "M000001"
        assert h.verify()[0]


def test_compare_says_what_the_two_calibrations_are(store_url, sessions):
    """An as-found / as-left pair is named as one by compare (its differences are the
    tables' as much as the machine's), and two given latest first are said to be
    (session 19: the table read "CHANGED" for every function of a pair, silently)."""
    from volcal.history.api import History
    from volcal.history.compare import pair_notes

    with History(store_url) as h:
        a1 = _add(h, sessions["a1"])                                # 2026-01-10
        a2 = _add(h, sessions["a2"])                                # 2026-07-10
        left = _add(h, sessions["a2same"], as_left_of=a2.id)       # its as-left
        assert pair_notes(h.store, a1.id, a2.id) == []
        assert pair_notes(h.store, a2.id, left.id) == [
            f"{left.id} is the as-left of {a2.id} (measured with the compensation tables "
            "active): the differences are what the tables corrected as much as the "
            f"machine's change; the machine's change since is the next as-found against "
            f"{left.id}"]
        assert pair_notes(h.store, a2.id, a1.id) == [
            f"{a2.id} was measured after {a1.id} (2026-07-10, 2026-01-10): the differences "
            "are the earlier minus the later (give the earlier first)"]
        df = h.compare(a2.id, left.id)
        assert df.attrs["notes"] == pair_notes(h.store, a2.id, left.id)
        assert len(df) > 0


# ------------------------------------------------------------------ 4. store hygiene
def test_no_store_is_made_by_a_typo(tmp_path, sessions):
    s = sessions["a1"]
    typo = tmp_path / "plnat" / "h.sqlite"
    for args in (["list"], ["show", "C000002"], ["trend", "VMC-A", "--parameter", "X.A"],
                 ["compare", "C000002", "C000003"], ["due"], ["verify"],
                 ["fleet", "-o", str(tmp_path / "f.html")], ["export", "-o", str(tmp_path / "x")],
                 ["interval", "VMC-A", "200"], ["export-qif", "C000002", "-o",
                                                 str(tmp_path / "q.qif")],
                 ["add", str(s), "--model", str(s / "model.json")]):
        r = _volcal("history", *args, "--db", str(typo))
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert (f"error: {typo}: no history here: the folder {typo.parent} does not exist "
                "(a typo? volcal history add --create makes a new store)") in r.stderr, args
        assert "Traceback" not in r.stderr
    assert not typo.parent.exists() and not (tmp_path / "x").exists()
    new = tmp_path / "h.sqlite"
    r = _volcal("history", "add", str(s), "--model", str(s / "model.json"), "--db", str(new))
    assert r.returncode == 2 and (f"error: {new}: no history file here (a typo? volcal "
                                  "history add --create makes a new store)") in r.stderr
    assert not new.exists()
    r = _volcal("history", "add", str(s), "--model", str(s / "model.json"), "--db",
                str(typo), "--create")
    assert r.returncode == 0 and r.stdout == "C000002\n", r.stderr
    assert f"note: created a new history at sqlite:///{typo}" in r.stderr
    assert _volcal("history", "verify", "--db", str(typo)).returncode == 0


def test_an_empty_database_is_no_history_without_create(store_url):
    from volcal.history.api import History
    from volcal.history.url import describe, resolve_url

    if not store_url.startswith("postgresql"):
        Path(store_url).write_bytes(b"")                   # an empty SQLite file
    with pytest.raises(VolcalInputError) as exc:
        History(store_url, create=False)
    assert str(exc.value) == (f"{describe(resolve_url(store_url))}: this database holds no "
                              "volcal history (volcal history add --create makes one there)")


def test_positions_outside_the_travel_are_refused(store_url, sessions):
    from volcal.history.api import History

    with History(store_url) as h:
        _add(h, sessions["a1"])
        with pytest.raises(VolcalInputError) as exc:
            h.trend("VMC-A", "EXX@4000")
        assert str(exc.value) == ("--parameter EXX@4000: 4000 mm is outside the travel of X "
                                  "in C000002 (0 to 800 mm)")
        with pytest.raises(VolcalInputError, match=r"-1 mm is outside the travel of Z"):
            h.trend("VMC-A", "EXZ@-1")
        assert h.trend("VMC-A", "EXX@800").value.notna().all()  # the end itself is in


def test_the_model_is_stored_once(store_url, sessions):
    from volcal.history.api import History

    s = sessions["a1"]
    with History(store_url) as h:
        r = _add(h, s)
        roles = {(f["role"], f["name"]) for f in r.files}
        model_parts = {p.name for p in s.glob("model.*")}
        assert {n for role, n in roles if role == "session"} == {
            p.name for p in s.iterdir() if p.is_file() and p.name not in model_parts}
        assert {n for role, n in roles if role in ("model", "model-part")} == model_parts
        stored = sum(len(h.store.file(r.id, role, n)) for role, n in roles)
        folder = sum(p.stat().st_size for p in s.iterdir() if p.is_file())
        assert stored == folder                               # every byte once
        from volcal.history.compare import load_record_model

        assert load_record_model(h.store, r.id) is not None


def test_dataframes_are_typed(store_url, sessions):
    from volcal.history.api import History
    from volcal.history.etalon import write_etalon

    with History(store_url) as h:
        a1, a2 = _add(h, sessions["a1"]), _add(h, sessions["a2"])
        from volcal.history.compare import load_record_model

        f = write_etalon(load_record_model(h.store, a1.id).errors,
                         sessions["a1"].parent / f"etalon-{abs(hash(store_url))}.txt")
        e = h.add_etalon(f, sessions["a1"], date="2026-03-01")
        res = h.results()
        assert pd.api.types.is_datetime64_dtype(res["date"])
        assert res["value"].dtype == res["U"].dtype == np.float64
        assert res[res.id == e.id]["U"].isna().all()          # no U: NaN, not None
        assert res[res.id == a1.id]["U"].notna().any()
        tr = h.trend("VMC-A", "EC0Y")
        assert list(tr.date) == [pd.Timestamp("2026-01-10"), pd.Timestamp("2026-03-01"),
                                 pd.Timestamp("2026-07-10")]
        assert tr["U"].dtype == np.float64 and np.isnan(tr["U"].iloc[1])
        cmp = h.compare(a1.id, a2.id)
        assert cmp["changed"].dtype == "boolean"
        assert cmp["U"].dtype == cmp["difference"].dtype == np.float64
        assert list(cmp.name[cmp.changed.fillna(False) & (cmp.test == "chi-square")]) \
            == ["EXX"]


def test_a_record_number_alone_is_answered_with_its_id(store_url, sessions):
    """Session 21: `volcal history show 2` and `--as-left-of 2` said "no record '2'"
    without saying that ids are C000002; a number (or a lower-case id) names the record of
    that number, which the message proposes."""
    from volcal.history.api import History

    with History(store_url) as h:
        _add(h, sessions["a2"])                              # M000001, C000002
        for given in ("2", "000002", "c000002"):
            with pytest.raises(VolcalInputError) as exc:
                h.show(given)
            assert str(exc.value).endswith(f"no record {given!r} in the history "
                                           f"{h.store.where}; did you mean C000002 "
                                           "(calibration)?"), str(exc.value)
        with pytest.raises(VolcalInputError) as exc:
            _add(h, sessions["a2same"], as_left_of="2")
        assert "did you mean C000002 (calibration)?" in str(exc.value)
        with pytest.raises(VolcalInputError) as exc:
            h.show("9")
        assert "ids are a letter and six digits, e.g. C000002" in str(exc.value)
        assert [r.id for r in h.list()] == ["M000001", "C000002"]    # nothing appended
