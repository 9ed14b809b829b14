"""A damaged or tampered store (issue 26, finding 4): clear messages, never a traceback,
never a write to a broken store; ``verify`` names the first broken record; ``--head``.

Each test starts from a copy of one store holding machine M000001 and its calibrations
C000002 (A) and C000003 (B, X scale +10 um/m), on SQLite (a copied file) and on
PostgreSQL (a database made from a template). The damage is done behind volcal's back:
``sqlite3`` without foreign keys, psycopg with the foreign-key triggers off.
"""

from __future__ import annotations

import hashlib
import itertools
import shutil
import sqlite3
from pathlib import Path

import pytest
from history_fixtures import history_two  # noqa: F401  (a fixture)

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal_cli_helpers import volcal_process

# the model's U drawn once per model in this process (tests/model_u_once.py)
pytestmark = pytest.mark.usefixtures("model_u_once")

_COPY = itertools.count()


def _volcal(*args: object):
    return volcal_process("history", *args, timeout=scaled_timeout(300))


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def base(request, history_two, tmp_path_factory):  # noqa: F811
    """A store with A and B stored (SQLite file, or a PostgreSQL template database)."""
    from volcal.history.api import History

    two = history_two
    if request.param == "sqlite":
        url = str(tmp_path_factory.mktemp("dmg") / "base.sqlite")
        shutil.copy(two["db"], url)
        with History(url) as h:
            h.add(two["b"], two["b"] / "model.json")
        return {"url": url, **two}
    from conftest import new_database

    url = new_database(request.getfixturevalue("postgres_server"))
    with History(url) as h:
        h.add(two["a"], two["a"] / "model.json")
        h.add(two["b"], two["b"] / "model.json")
    return {"url": url, **two}


@pytest.fixture
def store(base, tmp_path) -> str:
    """A fresh copy of the base store; its ``--db`` value."""
    url = base["url"]
    if not url.startswith("postgresql"):
        p = tmp_path / "h.sqlite"
        shutil.copy(url, p)
        return str(p)
    import psycopg

    server, name = url.rsplit("/", 1)
    copy = f"{name}_c{next(_COPY)}"
    with psycopg.connect(f"{server}/postgres", autocommit=True) as conn:
        conn.execute(f"CREATE DATABASE {copy} TEMPLATE {name}")
    return f"{server}/{copy}"


def _sql(url: str, *statements: str) -> None:
    """Run SQL behind volcal's back (no foreign keys)."""
    if url.startswith("postgresql"):
        import psycopg

        with psycopg.connect(url, autocommit=True) as conn:
            conn.execute("SET session_replication_role = replica")
            for s in statements:
                conn.execute(s)
        return
    with sqlite3.connect(url) as conn:
        for s in statements:
            conn.execute(s)
    conn.close()


def _snapshot(url: str) -> object:
    """Everything the store holds (bytes of the SQLite file; PostgreSQL: every row)."""
    if not url.startswith("postgresql"):
        return hashlib.sha256(Path(url).read_bytes()).hexdigest()
    import psycopg

    with psycopg.connect(url) as conn:
        return [conn.execute(f"SELECT * FROM {t} ORDER BY 1, 2").fetchall()
                for t in ("records", "results", "equipment")] + [
            conn.execute("SELECT record_seq, name, sha256, md5(content) FROM files "
                         "ORDER BY 1, 2").fetchall()]


def _where(url: str) -> str:
    from volcal.history.url import describe, resolve_url

    return describe(resolve_url(url))


# --------------------------------------------------------------------- verify names it
@pytest.mark.parametrize("damage, first, why", [
    (["UPDATE results SET value = value + 1 WHERE name = 'X.A' AND record_seq = 2"],
     "C000002 (record 2)", "its content does not match its hash"),
    (["UPDATE files SET content = content || 'x' WHERE name = 'session.toml' "
      "AND record_seq = 3"],
     "C000003 (record 3)", "file session.toml was altered"),
    (["DELETE FROM results WHERE record_seq = 2", "DELETE FROM files WHERE record_seq = 2",
      "DELETE FROM equipment WHERE record_seq = 2", "DELETE FROM records WHERE seq = 2"],
     "C000003 (record 3)", "record 2 is missing (deleted)"),
    (["UPDATE records SET prev_hash = (SELECT prev_hash FROM records WHERE seq = 2) "
      "WHERE seq = 3"],
     "C000003 (record 3)", "its link to the previous record is broken (reordered, or a "
     "record before it rewritten)"),
    (["INSERT INTO results (record_seq, name, value, \"U\", unit) "
      "VALUES (4, 'X.A', 1.0, NULL, 'um')"],
     "record 4", "results rows (X.A) planted for record 4, which does not exist (not "
     "written by volcal)"),
    (["INSERT INTO equipment (record_seq, position, role) VALUES (0, 0, 'laser')"],
     "record 0", "equipment rows (0) pointing to record 0, which does not exist"),
])
def test_verify_names_first_broken(store, damage, first, why):
    before = _volcal("verify", "--db", store)
    assert before.returncode == 0 and "chain intact: 3 records" in before.stdout
    _sql(store, *damage)
    r = _volcal("verify", "--db", store)
    assert r.returncode == 1, r.stdout + r.stderr
    assert r.stdout.startswith(f"chain BROKEN at {first}: {why}; last good head "), r.stdout
    assert "Traceback" not in r.stderr


def test_add_refuses_broken_chain(store, base):
    """Nothing appended to a broken chain; the message names the first broken record."""
    from volcal.history.api import History

    _sql(store, "UPDATE results SET value = value + 1 WHERE name = 'X.A' AND record_seq = 2")
    snap = _snapshot(store)
    with History(store) as h, pytest.raises(VolcalInputError) as exc:
        h.add(base["b"], base["b"] / "model.json")
    assert str(exc.value) == (f"{_where(store)}: the history is broken at C000002 (record "
                              "2): its content does not match its hash; nothing was added "
                              "(volcal history verify tells the rest)")
    assert _snapshot(store) == snap


def test_planted_row_cannot_make_an_honest_add_look_tampered(store, base):
    """A results row planted for the next record: verify reports it, add refuses."""
    from volcal.history.api import History

    _sql(store, "INSERT INTO results (record_seq, name, value, \"U\", unit) "
                "VALUES (4, 'V.E_VXYZ', 0.5, NULL, 'um')")
    snap = _snapshot(store)
    with History(store) as h:
        with pytest.raises(VolcalInputError, match=r"the history is broken at record 4: "
                           r"results rows \(V.E_VXYZ\) planted for record 4"):
            h.add(base["b"], base["b"] / "model.json")
        assert h.verify()[1] == "record 4"
    assert _snapshot(store) == snap


def test_foreign_keys_enforced(store):
    """Through volcal's connections a row pointing to no record is refused (both backends)."""
    from sqlalchemy import text
    from sqlalchemy.exc import IntegrityError

    from volcal.history.api import History

    with History(store) as h:
        with pytest.raises(IntegrityError), h.store.engine.begin() as conn:
            conn.execute(text("INSERT INTO results (record_seq, name, value, \"U\", unit) "
                              "VALUES (99, 'X.A', 1.0, NULL, 'um')"))
        assert h.verify()[0]


# ------------------------------------------------------------------ readers say so
def test_readers_warn_about_an_altered_record(store, tmp_path):
    _sql(store, "UPDATE results SET value = value + 5 WHERE name = 'X.A' AND record_seq = 3")
    warn = (f"warning: record C000003 of the history {_where(store)}: its content does not "
            "match its hash; what is shown of it may have been altered (volcal history "
            "verify)")
    for args in (["show", "C000003"], ["trend", "VMC-1", "--parameter", "X.A"],
                 ["list"], ["fleet", "-o", str(tmp_path / "f.html")],
                 ["export", "-o", str(tmp_path / "pq")]):
        r = _volcal(*args, "--db", store)
        assert r.returncode == 0, (args, r.stderr)
        assert warn in " ".join(r.stderr.split()), (args, r.stderr)
    # the unaltered record is shown without a warning
    r = _volcal("show", "C000002", "--db", store)
    assert r.returncode == 0 and "warning" not in r.stderr


def test_compare_checks_the_stored_model_digest(store):
    """An altered model.npz is not unpacked: compare refuses, naming file and record."""
    _sql(store, "UPDATE files SET content = content || 'x' WHERE name = 'model.npz' "
                "AND record_seq = 3")
    r = _volcal("compare", "C000002", "C000003", "--db", store)
    assert r.returncode == 2, r.stdout + r.stderr
    msg = " ".join(r.stderr.split())
    assert (f"{_where(store)}: stored file model.npz of record C000003 does not match its "
            "sha256 (altered in the store): not used (volcal history verify)") in msg
    assert "Traceback" not in r.stderr


# ----------------------------------------------------------------------- SQLite only
def _sqlite_only(store: str) -> None:
    if store.startswith("postgresql"):
        pytest.skip("SQLite file damage")


@pytest.mark.parametrize("text", ["'edited in place'", "CAST(X'FFFE00C3' AS TEXT)"])
def test_text_in_blob_column(store, text):
    """TEXT written into the BLOB column (valid or not UTF-8): an altered file, no crash."""
    _sqlite_only(store)
    _sql(store, f"UPDATE files SET content = {text} WHERE name = 'model.json' "
                "AND record_seq = 2")
    r = _volcal("verify", "--db", store)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert r.stdout.startswith("chain BROKEN at C000002 (record 2): file model.json was "
                               "altered; last good head ")
    # the export keeps what is stored, as bytes, and says which record's file is altered
    r = _volcal("export", "-o", str(Path(store).parent / "pq"), "--db", store)
    assert r.returncode == 0, r.stderr
    assert (f"warning: record C000002 of the history {_where(store)}: stored file model.json "
            "does not match its sha256 (altered in the store); what is shown of it may have "
            "been altered (volcal history verify)") in " ".join(r.stderr.split())
    # the model is not unpacked
    r = _volcal("trend", "VMC-1", "--parameter", "EXX@400", "--db", store)
    assert r.returncode == 2 and "stored file model.json of record C000002 does not match " \
        "its sha256" in " ".join(r.stderr.split())


def test_due_does_not_use_an_altered_session_file(store):
    """due takes the kinds of test from the record's payload (in its hash), not from the
    stored session.toml: an altered file changes nothing there; verify names it."""
    before = _volcal("due", "--db", store).stdout
    _sql(store, "UPDATE files SET content = content || 'x' WHERE name = 'session.toml' "
                "AND record_seq = 3")
    r = _volcal("due", "--db", store)
    assert r.returncode == 0 and r.stderr == "" and r.stdout == before, r.stderr
    assert "\tdiagonal\t" in before and "\tlinear\t" in before
    v = _volcal("verify", "--db", store)
    assert v.returncode == 1 and "file session.toml was altered" in v.stdout


def test_corrupted_page_clean_message(store, base):
    """Pages of garbage: every command a clear message naming the store, nothing written.

    Every page from the third on (the header and the first table page intact): which
    pages a command reads depends on the store's layout, and with every third page
    ``show`` found its rows intact once the model files' binary parts shrank (session 14,
    the part between the readings stored as one variance per parameter) and succeeded."""
    _sqlite_only(store)
    p = Path(store)
    data = bytearray(p.read_bytes())
    page = 4096
    n = len(data) // page
    assert n > 6
    for k in range(2, n):                         # every page from the third on
        data[k * page + 100:k * page + 600] = b"\xa5" * 500
    p.write_bytes(bytes(data))
    snap = _snapshot(store)
    for args in (["list"], ["verify"], ["show", "C000002"], ["compare", "C000002", "C000003"],
                 ["add", str(base["b"]), "--model", str(base["b"] / "model.json")]):
        r = _volcal(*args, "--db", store)
        assert "Traceback" not in r.stderr, (args, r.stderr)
        assert r.returncode in (1, 2), (args, r.returncode, r.stdout, r.stderr)
        if r.returncode == 2:
            assert str(p) in " ".join(r.stderr.split()), (args, r.stderr)
    assert _snapshot(store) == snap


@pytest.mark.parametrize("size, why", [
    (1, "a file of 1 bytes without a table: truncated, or not a database"),
    (10, "file is not a database"),
    (100, "database disk image is malformed"),
    (4095, "database disk image is malformed")])
def test_truncated_store_not_given_a_new_schema(store, size, why):
    """SQLite reads a file shorter than its header as an empty database: refused, and
    not given a new schema."""
    _sqlite_only(store)
    p = Path(store)
    p.write_bytes(p.read_bytes()[:size])
    for args in (["verify"], ["list"], ["interval", "VMC-1", "30"]):
        r = _volcal(*args, "--db", store)
        assert r.returncode == 2, (args, r.stdout)
        assert f"{_where(store)}: not a usable history database ({why})" in \
            " ".join(r.stderr.split()), r.stderr
    assert p.stat().st_size == size


# ------------------------------------------------------------------------- --head
def test_verify_head(store):
    r = _volcal("verify", "--db", store)
    head = r.stdout.split("head ")[-1].strip()
    assert len(head) == 64
    r = _volcal("verify", "--head", head, "--db", store)
    assert r.returncode == 0
    assert r.stdout.splitlines()[-1] == ("kept head is record 3 of 3: it and every record "
                                         "before it unchanged; 0 records appended since")
    # the first record's hash, kept: two records appended since
    from volcal.history.api import History

    with History(store) as h:
        first = h.list()[0].hash
    r = _volcal("verify", "--head", first.upper(), "--db", store)
    assert r.returncode == 0 and r.stdout.splitlines()[-1].endswith("2 records appended since")
    # history rewritten from record 2 on, every hash recomputed: intact, but not the head
    _rewrite_from(store, 2)
    r = _volcal("verify", "--db", store)
    assert r.returncode == 0, r.stdout
    r = _volcal("verify", "--head", head, "--db", store)
    assert r.returncode == 1
    assert r.stdout.splitlines()[-1] == (f"kept head {head} is NOT on the chain: a record up "
                                         "to it was rewritten or deleted since that head was "
                                         "kept")
    r = _volcal("verify", "--head", first, "--db", store)
    assert r.returncode == 0                     # record 1 untouched by the rewrite
    r = _volcal("verify", "--head", "abc", "--db", store)
    assert r.returncode == 2 and "expected the 64 hex digits" in r.stderr


def _rewrite_from(url: str, seq: int) -> None:
    """Alter record ``seq``'s result and recompute every hash from it on (a forger)."""
    from sqlalchemy import select, update

    from volcal.history import schema as t
    from volcal.history.api import History
    from volcal.history.chain import record_hash

    with History(url) as h, h.store.engine.begin() as conn:
        conn.execute(update(t.results).where(t.results.c.record_seq == seq,
                                             t.results.c.name == "X.A")
                     .values(value=t.results.c.value + 1))
        rows = conn.execute(select(t.records).order_by(t.records.c.seq)).mappings().all()
        prev = None
        for r in rows:
            if r["seq"] < seq:
                prev = r["hash"]
                continue
            ch = [[dict(x) for x in conn.execute(select(*cols).where(
                tbl.c.record_seq == r["seq"])).mappings()] for tbl, cols in (
                (t.files, (t.files.c.role, t.files.c.name, t.files.c.sha256)),
                (t.results, tuple(t.results.c)), (t.equipment, tuple(t.equipment.c)))]
            new = record_hash(prev, dict(r, prev_hash=prev), *ch)
            conn.execute(update(t.records).where(t.records.c.seq == r["seq"])
                         .values(prev_hash=prev, hash=new))
            prev = new


def test_schema_name_not_utf8(store):
    """A table name in the schema page that is not UTF-8: a clear message, no traceback."""
    _sqlite_only(store)
    p = Path(store)
    data = bytearray(p.read_bytes())
    i = data.index(b"tablerecordsrecords") + len(b"table")
    data[i:i + 7] = b"\xa4\xff\xa4\xff\xa4\xff\xa4"          # the name 'records'
    p.write_bytes(bytes(data))
    for args in (["verify"], ["list"]):
        r = _volcal(*args, "--db", store)
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        assert (f"{_where(store)}: the history database cannot be read or written ("
                in " ".join(r.stderr.split())), r.stderr
