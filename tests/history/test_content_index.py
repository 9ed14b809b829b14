"""Revision 0004: the content digest of each calibration in an indexed column, unique where
the store never held duplicates; a store that did keeps a non-unique index and verify
names the duplicates; the add's incremental check (volcal.history.heads); one machine's
commands read only its records. SQLite and PostgreSQL.
"""

from __future__ import annotations

import json

import pytest
from sqlalchemy import inspect, text

from volcal.errors import VolcalInputError
from volcal_cli_helpers import volcal_process

TRAVEL = [[0, 800], [0, 600], [0, 500]]
DIGEST = "ab" * 32


@pytest.fixture(autouse=True)
def _own_heads(tmp_path, monkeypatch):
    """Kept heads in a file of the test's own (not the user's cache)."""
    monkeypatch.setenv("VOLCAL_HISTORY_HEADS", str(tmp_path / "heads.json"))


def _index(engine) -> dict:
    return {i["name"]: i for i in inspect(engine).get_indexes("records")}


def _old_store(url: str, digests: list[str]) -> None:
    """A store at revision 0003: machine M000001 and one calibration per digest, inserted
    as volcal before 0004 wrote them (a retried add appended the same content again)."""
    from volcal.history.chain import GENESIS, record_hash
    from volcal.history.engine import make_engine, migrate
    from volcal.history.url import resolve_url

    eng = make_engine(resolve_url(url))
    migrate(eng, "0003")
    prev = GENESIS
    with eng.begin() as conn:
        for seq in range(1, len(digests) + 2):
            cal = seq > 1
            payload = ({"machine": {"name": "old"}, "content_sha256": digests[seq - 2]}
                       if cal else {"machine": {"name": "old", "chain": "XYFZ",
                                                "travel_mm": TRAVEL}, "interval_days": 365})
            row = {"seq": seq, "id": f"{'C' if cal else 'M'}{seq:06d}",
                   "kind": "calibration" if cal else "machine",
                   "machine_id": "M000001" if cal else None,
                   "date": f"2025-01-0{seq}" if cal else None,
                   "created": "2025-01-01T00:00:00+00:00", "supersedes": None,
                   "as_left_of": None, "report_id": None,
                   "payload": json.dumps(payload, sort_keys=True, separators=(",", ":")),
                   "prev_hash": prev}
            row["hash"] = prev = record_hash(prev, row, [], [], [])
            conn.execute(text(
                "INSERT INTO records (seq, id, kind, machine_id, date, created, supersedes, "
                "as_left_of, report_id, payload, prev_hash, hash) VALUES (:seq, :id, :kind, "
                ":machine_id, :date, :created, :supersedes, :as_left_of, :report_id, "
                ":payload, :prev_hash, :hash)"), row)
    eng.dispose()


def test_new_store_has_the_unique_index(store_url):
    from volcal.history.api import History

    with History(store_url) as h:
        idx = _index(h.store.engine)
    assert idx["ix_records_content_sha256"]["column_names"] == ["content_sha256"]
    assert idx["ix_records_content_sha256"]["unique"]
    assert {"ix_records_machine_id", "ix_records_supersedes", "ix_records_kind"} <= set(idx)


def test_upgrade_without_duplicates_is_unique(store_url):
    """0003 -> 0004: the column filled from the payloads, the index unique; the database
    itself refuses a second record of that content."""
    from volcal.history.api import History

    _old_store(store_url, [DIGEST, "cd" * 32])
    with History(store_url) as h:
        assert _index(h.store.engine)["ix_records_content_sha256"]["unique"]
        with h.store.engine.connect() as conn:
            col = dict(conn.execute(text("SELECT id, content_sha256 FROM records")).all())
        assert col == {"M000001": None, "C000002": DIGEST, "C000003": "cd" * 32}
        assert h.verify()[0]
        with pytest.raises(Exception, match="(?i)unique"), h.store.engine.begin() as conn:
            conn.execute(text("UPDATE records SET content_sha256 = :d WHERE id = 'C000003'"),
                         {"d": DIGEST})


def test_upgrade_with_duplicates(store_url):
    """A store that held the same content twice (before 0004): the index is not unique,
    the store keeps working, verify passes and names the duplicates; a retried add of that
    content returns the newest of them."""
    from volcal.history.api import History
    from volcal.history.store import NewRecord

    _old_store(store_url, [DIGEST, "cd" * 32, DIGEST])
    with History(store_url) as h:
        assert not _index(h.store.engine)["ix_records_content_sha256"]["unique"]
        again = h.store.append(NewRecord("calibration", {"content_sha256": DIGEST},
                                         machine_id="M000001", date="2025-02-01"))
        assert again.already_stored and again.id == "C000004"
    r = volcal_process("history", "verify", "--db", store_url)
    assert r.returncode == 0, r.stdout
    assert r.stdout.splitlines()[1] == (
        "note: C000002, C000004 hold the same readings and model (added more than once "
        "before schema revision 0004 refused it; records are never deleted, a retried add "
        "returns the newest)")


def test_digest_column_altered_is_named(store_url):
    """The column is outside the hash: verify checks it against the payload."""
    from volcal.history.api import History

    _old_store(store_url, [DIGEST])
    History(store_url).close()                                     # upgraded to 0004
    from volcal.history.engine import make_engine
    from volcal.history.url import resolve_url

    eng = make_engine(resolve_url(store_url))
    with eng.begin() as conn:
        conn.execute(text("UPDATE records SET content_sha256 = :d WHERE id = 'C000002'"),
                     {"d": "ef" * 32})
    eng.dispose()
    r = volcal_process("history", "verify", "--db", store_url)
    assert r.returncode == 1
    assert r.stdout.startswith(
        "chain BROKEN at C000002 (record 2): its content digest column "
        "(records.content_sha256) does not match its payload (altered in the store)")


def _payload_edit(url: str, rid: str) -> None:
    """Alter a record's payload in the store (its hash left as it was)."""
    from volcal.history.engine import make_engine
    from volcal.history.url import resolve_url

    eng = make_engine(resolve_url(url))
    with eng.begin() as conn:
        conn.execute(text("UPDATE records SET date = '1999-01-01' WHERE id = :i"), {"i": rid})
    eng.dispose()


def test_add_checks_after_the_kept_head(store_url, tmp_path, monkeypatch):
    """add re-hashes only the records after the head this machine last checked while
    nobody else wrote to the store; once anyone did (an alteration with another program),
    the whole chain is checked and the alteration refused, wherever it is."""
    from volcal.history import integrity
    from volcal.history.api import History
    from volcal.history.heads import kept_head
    from volcal.history.store import NewRecord

    trusted: list = []
    real = integrity.check_chain

    def spy(conn, contents=True, trusted_head=None, **kw):
        trusted.append(kw.get("trusted", trusted_head))
        return real(conn, contents, kw.get("trusted", trusted_head))

    monkeypatch.setattr(integrity, "check_chain", spy)

    def interval(h: History, days: int):
        return h.store.append(NewRecord("interval", {"interval_days": days},
                                        machine_id="M000001"))

    _old_store(store_url, [DIGEST, "cd" * 32])
    with History(store_url) as h:
        assert kept_head(h.store.key) is None
        assert h.store.check().ok                                   # verify keeps the head
        assert interval(h, 30).id == "I000004"                      # checked after record 3
        assert interval(h, 31).id == "I000005"                      # after record 4
    assert [t[0] for t in trusted[1:]] == [3, 4]
    _payload_edit(store_url, "C000002")                             # another program
    with History(store_url) as h, pytest.raises(VolcalInputError) as exc:
        interval(h, 32)
    assert trusted[-1] is None                                      # the whole chain
    assert ("the history is broken at C000002 (record 2): its content does not match its "
            "hash; nothing was added") in str(exc.value)


def test_one_machine_reads_only_its_records(store_url, monkeypatch):
    """trend, list --machine, fleet --machine and compare of one machine re-hash only the
    records of that machine and its machine record: no full-store read."""
    from volcal.history import integrity
    from volcal.history.api import History
    from volcal.history.fleet import fleet_html
    from volcal.history.machines import machine_payload
    from volcal.history.store import NewRecord
    from volcal.session.identity import MachineIdentity

    with History(store_url) as h:
        ids = {}
        for name in ("A", "B"):
            ident = MachineIdentity(name=name, chain="XYFZ",
                                    travel_mm=tuple(map(tuple, TRAVEL)), serial=name)
            mid = h.store.append(NewRecord("machine", machine_payload(ident))).id
            ids[name] = [h.store.append(NewRecord(
                "calibration", {"machine": {"name": name}, "content_sha256": f"{name}{k}"},
                machine_id=mid, date=f"202{k}-01-01",
                results=[("X.A", 1.0 + k, 0.5, "um")])).id for k in range(3)]
        seen: list[str] = []
        real = integrity.record_damage

        def counting(row, *a):
            seen.append(row["id"])
            return real(row, *a)

        monkeypatch.setattr(integrity, "record_damage", counting)
        rows = h.trend("A", "X.A")
        assert list(rows.value) == [1.0, 2.0, 3.0] and list(rows.U) == [0.5] * 3
        fleet_html(h, machine="A")
        h.compare(ids["A"][0], ids["A"][2])
        assert set(seen) == {"M000001", *ids["A"]}      # not even B's machine record
