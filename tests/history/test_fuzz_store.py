"""Fuzz test of damaged history stores (hypothesis): bytes flipped, pages of garbage,
files truncated, columns overwritten with values of any type.

Every command on a damaged store either gives a clear message naming the store (exit code
2), or reports the broken chain (``verify``, exit code 1), or answers correctly: never a
traceback. A store whose chain is broken (or that cannot be read) is never written to:
the writer (``volcal history interval``, which appends a record through the same checks
as ``add``) is refused and the file keeps every byte. A store ``verify`` finds intact
lists the same records as before the damage.

The default profile runs a fixed small set (``make test``); the slow run draws new
damage: ``HYPOTHESIS_PROFILE=fuzz .venv/bin/pytest tests/history/test_fuzz_store.py``
(10^4 damaged stores; README).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sqlite3
import tempfile
from pathlib import Path

import pytest
from history_fixtures import history_two  # noqa: F401  (a fixture)
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from volcal_cli_helpers import volcal_process

FUZZ = os.environ.get("HYPOTHESIS_PROFILE") == "fuzz"
N_STORES = int(os.environ.get("VOLCAL_FUZZ_STORES", "10000")) if FUZZ else 8
"""Damaged stores: 10^4 in the slow run (``VOLCAL_FUZZ_STORES`` for a shorter one), a fixed
8 in ``make test``."""

PAGE = 4096
COLUMNS = {"records": ("seq", "id", "kind", "machine_id", "date", "created", "supersedes",
                       "payload", "prev_hash", "hash"),
           "results": ("record_seq", "name", "value", "U", "unit"),
           "files": ("record_seq", "name", "sha256", "content"),
           "equipment": ("record_seq", "position", "role", "serial"),
           "alembic_version": ("version_num",)}
VALUES = st.one_of(st.none(), st.integers(-5, 10**6), st.floats(allow_nan=True),
                   st.text(max_size=40), st.binary(max_size=64))


class _Intact(dict):
    def __repr__(self) -> str:  # hypothesis prints the arguments of a failing example
        return f"<intact store {self['path']}>"


@pytest.fixture(scope="module")
def intact(history_two, tmp_path_factory):  # noqa: F811
    """A store with A and B (SQLite file) and what ``list --json --all`` says of it."""
    from volcal.history.api import History

    p = tmp_path_factory.mktemp("fuzzstore") / "base.sqlite"
    shutil.copy(history_two["db"], p)
    with History(str(p)) as h:
        h.add(history_two["b"], history_two["b"] / "model.json")
    r = volcal_process("history", "list", "--json", "--all", "--db", p)
    assert r.returncode == 0
    return _Intact(path=p, bytes=p.read_bytes(), list=r.stdout)


def _refused_by_add(path: Path) -> bool:
    """Whether ``add``'s own check finds the store broken or unreadable (the chain, its
    records and rows; a stored file's content is checked by verify and by its readers)."""
    from volcal.errors import VolcalInputError
    from volcal.history.store import Store

    try:
        s = Store(str(path))
    except VolcalInputError:
        return True
    try:
        return not s.verify(contents=False)[0]
    except VolcalInputError:
        return True
    finally:
        s.close()


def _byte_damage(data: bytearray, draw) -> None:
    """Flip bytes, write a block of garbage, or truncate (offsets biased to the b-tree
    pages at the front of the file, where the records and results live)."""
    n = len(data)
    where = draw(st.one_of(st.integers(0, min(n - 1, 40 * PAGE)), st.integers(0, n - 1)))
    kind = draw(st.sampled_from(["flip", "garbage", "truncate", "page"]))
    if kind == "flip":
        for k in range(draw(st.integers(1, 8))):
            i = min(n - 1, where + k * draw(st.integers(1, 97)))
            data[i] ^= draw(st.integers(1, 255))
    elif kind == "garbage":
        block = draw(st.binary(min_size=1, max_size=600))
        data[where:where + len(block)] = block
    elif kind == "page":
        start = (where // PAGE) * PAGE
        data[start:start + PAGE] = draw(st.binary(min_size=PAGE, max_size=PAGE))
    else:                                      # (an empty file is a new store)
        del data[max(1, where):]


def _column_damage(path: Path, draw) -> None:
    """Overwrite one cell of a table with a value of any type (no foreign keys)."""
    table = draw(st.sampled_from(sorted(COLUMNS)))
    col = draw(st.sampled_from(COLUMNS[table]))
    row = draw(st.integers(0, 40))
    value = draw(VALUES)
    conn = sqlite3.connect(path)
    try:
        with conn:
            conn.execute(f'UPDATE {table} SET "{col}" = ? WHERE rowid = (SELECT rowid FROM '
                         f"{table} LIMIT 1 OFFSET ?)", (value, row))
    except (sqlite3.Error, UnicodeDecodeError):  # a constraint, or a file damaged already
        pass
    finally:
        conn.close()


def _digest(path: Path) -> str | None:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else None


def _clean(r, path: Path) -> None:
    """No traceback; exit 0, 1 (verify: broken) or 2 with a message (a damaged database
    named by its path; a damaged record's content may give the command's own message)."""
    assert "Traceback" not in r.stderr, r.stderr
    assert r.returncode in (0, 1, 2), (r.returncode, r.stderr)
    if r.returncode == 2:
        assert r.stderr.startswith("error: "), r.stderr
        if "cannot be read or written" in r.stderr or "not a usable" in r.stderr:
            assert str(path) in " ".join(r.stderr.split()), r.stderr


@settings(deadline=None, max_examples=N_STORES, print_blob=True,
          phases=[Phase.explicit, Phase.reuse, Phase.generate],  # no slow shrinking
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_damaged_store(intact, data):
    with tempfile.TemporaryDirectory(prefix="volcal-fuzz-store-") as tmp:
        path = Path(tmp) / "h.sqlite"
        raw = bytearray(intact["bytes"])
        how = data.draw(st.sampled_from(["bytes", "column", "both"]))
        if how in ("bytes", "both"):
            _byte_damage(raw, data.draw)
        path.write_bytes(bytes(raw))
        if how in ("column", "both"):
            _column_damage(path, data.draw)
        before = _digest(path)
        db = ("--db", path)
        ver = volcal_process("history", "verify", *db)
        _clean(ver, path)
        for args in (["list", "--json", "--all"], ["show", "C000003", "--json"],
                     ["trend", "VMC-1", "--parameter", "X.A", "--json"], ["due"]):
            r = volcal_process("history", *args, *db)
            _clean(r, path)
            if args[0] == "list" and ver.returncode == 0:
                assert r.stdout == intact["list"]      # intact: the same records
        if data.draw(st.booleans()):                  # the change test (slower)
            _clean(volcal_process("history", "compare", "C000002", "C000003", *db), path)
        assert _digest(path) == before                # the readers wrote nothing
        refused = _refused_by_add(path)
        assert _digest(path) == before
        if ver.returncode == 0:
            assert not refused
        w = volcal_process("history", "interval", "VMC-1", "30", *db)
        _clean(w, path)
        if refused:                                  # broken or unreadable: never written
            assert w.returncode == 2, (w.stdout, ver.stdout)
            assert _digest(path) == before


def _check(path: Path, contents: bool) -> bool:
    """Whether the store's chain check passes (False: broken, or the database unreadable)."""
    from volcal.errors import VolcalInputError
    from volcal.history.store import Store

    try:
        s = Store(str(path), create=False)
    except VolcalInputError:
        return False
    try:
        return bool(s.check(contents).ok)
    except VolcalInputError:
        return False
    finally:
        s.close()


def test_verify_reads_every_page_add_reads(intact, tmp_path):
    """A page of garbage in the first 40: when ``add``'s check (``contents=False``)
    cannot read the store or finds it broken, ``verify`` does not call it intact.

    Found by the fuzz run (a page of garbage at offset 41625, page 11: ``verify`` said
    "chain intact: 3 records" while ``add`` met "database disk image is malformed"):
    ``verify`` read the children record by record through the index and never reached the
    damaged page, which the add's table scan did; verify now reads every child row in one
    pass as the add does."""
    data = intact["bytes"]
    path = tmp_path / "h.sqlite"
    missed = []
    for k in range(1, min(40, len(data) // PAGE)):   # the b-trees at the front (not the
        # files' content pages behind them), the header's page left alone
        raw = bytearray(data)
        raw[k * PAGE:(k + 1) * PAGE] = bytes([0xA5]) * PAGE
        path.write_bytes(bytes(raw))
        if _check(path, True) and not _check(path, False):
            missed.append(k + 1)
    assert missed == []


def test_readers_write_nothing_on_a_damaged_header(intact, tmp_path):
    """Garbage over the header's page count (offset 27-29): every reader left the file as
    it was. Found by the fuzz run (draws ``bytes``, offset 27, ``garbage`` b'<\\xec\\xd1'):
    opening the store took the writers' lock, a write transaction, and committing it made
    SQLite rewrite the header (change counter and page count) of a store only read."""
    path = tmp_path / "h.sqlite"
    raw = bytearray(intact["bytes"])
    raw[27:30] = b"<\xec\xd1"
    path.write_bytes(bytes(raw))
    before = _digest(path)
    for args in (["verify"], ["list", "--json", "--all"], ["show", "C000003", "--json"],
                 ["trend", "VMC-1", "--parameter", "X.A", "--json"], ["due"],
                 ["compare", "C000002", "C000003"]):
        r = volcal_process("history", *args, "--db", path)
        _clean(r, path)
        assert _digest(path) == before, args


@pytest.mark.parametrize("value", [95, "x", "2026-13-40", None])
def test_due_and_fleet_on_a_damaged_date(intact, tmp_path, value):
    """A record's date overwritten (found by the fuzz run: ``records.date`` = 95 made
    ``due`` die with "Invalid isoformat string"): ``due`` and ``fleet`` answer without the
    damaged record, name it as damaged, and write nothing to the store."""
    path = tmp_path / "h.sqlite"
    path.write_bytes(intact["bytes"])
    conn = sqlite3.connect(path)
    with conn:
        conn.execute("UPDATE records SET date = ? WHERE id = 'C000003'", (value,))
    conn.close()
    before = _digest(path)
    r = volcal_process("history", "due", "--json", "--db", path)
    _clean(r, path)
    assert r.returncode == 0, r.stderr
    assert "C000003" in r.stderr                        # named as damaged
    rows = __import__("json").loads(r.stdout)
    assert rows and all(row["last"] is None or row["last"][:4].isdigit() for row in rows)
    f = volcal_process("history", "fleet", "-o", tmp_path / "fleet.html", "--db", path)
    _clean(f, path)
    assert f.returncode == 0, f.stderr
    assert _digest(path) == before
