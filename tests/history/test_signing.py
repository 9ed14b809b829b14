"""Signed records (Ed25519) and the certificate's number, on SQLite and PostgreSQL.

The forger of these tests has full write access to the database and knows how the chain
is computed (:func:`volcal.history.chain.record_hash`): the chain alone cannot catch him
(``verify`` says intact), the public key does.
"""

from __future__ import annotations

import json
import os
import stat

import history_fixtures as _fx
import pytest

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal_cli_helpers import volcal_process

# the model's U drawn once per model in this process (tests/model_u_once.py)
pytestmark = pytest.mark.usefixtures("model_u_once")

# pytest fixtures shared by the history tests (see history_fixtures.py)
history_two = _fx.history_two


@pytest.fixture(scope="module")
def keys(tmp_path_factory):
    """The laboratory's key pair and a forger's."""
    from volcal.history.signing import new_key_pair

    tmp = tmp_path_factory.mktemp("keys")
    lab = new_key_pair(tmp / "lab")
    other = new_key_pair(tmp / "other")
    return {"lab": lab, "other": other}


def _rows(h) -> list[dict]:
    from sqlalchemy import select

    from volcal.history import schema as t

    with h.store.engine.connect() as conn:
        return [dict(r) for r in conn.execute(select(t.records).order_by(t.records.c.seq))
                .mappings()]


def _forge_append(h, signature=None, key_id=None) -> str:
    """Append an interval record behind volcal's back: right link, recomputed hash."""
    from sqlalchemy import insert

    from volcal.history import schema as t
    from volcal.history.chain import record_hash

    head = _rows(h)[-1]
    seq = head["seq"] + 1
    row = {"seq": seq, "id": f"I{seq:06d}", "kind": "interval", "machine_id": "M000001",
           "date": None, "created": "2026-11-26T10:00:00+00:00", "supersedes": None,
           "as_left_of": None, "report_id": None, "payload": '{"interval_days":3650}',
           "prev_hash": head["hash"]}
    row["hash"] = record_hash(head["hash"], row, [], [], [])
    with h.store.engine.begin() as conn:
        conn.execute(insert(t.records).values(**row, signature=signature, key_id=key_id))
    return row["hash"]


def _unforge(h, seq: int) -> None:
    from sqlalchemy import delete

    from volcal.history import schema as t

    with h.store.engine.begin() as conn:
        conn.execute(delete(t.records).where(t.records.c.seq == seq))


def test_key_pair_files(tmp_path, keys):
    """The private key is 0600, the public key is not secret; a key is never overwritten."""
    priv, pub, kid = keys["lab"]
    assert stat.S_IMODE(priv.stat().st_mode) == 0o600
    assert priv.read_bytes().startswith(b"-----BEGIN PRIVATE KEY-----")
    assert pub.read_bytes().startswith(b"-----BEGIN PUBLIC KEY-----")
    from volcal.history.signing import Signer, load_public_key, new_key_pair

    assert Signer(priv).key_id == load_public_key(pub)[1] == kid and len(kid) == 16
    with pytest.raises(VolcalInputError, match="a key is already there: a key pair is never "
                       r"overwritten \(move it away, or choose another folder with -o\)"):
        new_key_pair(priv.parent)
    # no temporary file left beside the keys
    assert sorted(p.name for p in priv.parent.iterdir()) == ["history-key.pem",
                                                              "history-key.pub.pem"]


def test_signed_round_trip(store_url, history_two, keys):
    """Every record appended with the key is signed; the public key vouches for all."""
    from volcal.history.api import History

    priv, pub, kid = keys["lab"]
    with History(store_url, private_key=priv) as h:
        a = h.add(history_two["a"], history_two["a"] / "model.json")
        assert a.key_id == kid and len(a.signature) == 128
        assert h.verify()[0]
        sig = h.verify_signatures([pub])
        assert sig.ok and sig.signed == sig.n == 2 and sig.last_signed == "C000002 (record 2)"
        # a key that did not sign is told apart from a bad signature
        bad = h.verify_signatures([keys["other"][1]])
        assert not bad.ok and bad.first_bad == "M000001 (record 1)"
        assert bad.why == f"signed by key {kid}, not by the key given ({keys['other'][2]})"
        # either of two keys (a key changed over the years)
        assert h.verify_signatures([keys["other"][1], pub]).ok


def test_forged_append_caught(store_url, history_two, keys):
    """A record appended with a recomputed hash: the chain is intact, the signatures are not."""
    from volcal.history.api import History
    from volcal.history.signing import Signer

    priv, pub, kid = keys["lab"]
    with History(store_url, private_key=priv) as h:
        h.add(history_two["a"], history_two["a"] / "model.json")
        # unsigned
        _forge_append(h)
        assert h.verify()[0]                                  # the chain alone is fooled
        sig = h.verify_signatures([pub])
        assert not sig.ok and sig.first_bad == "I000003 (record 3)"
        assert sig.why == "it is not signed, after signed records (last signed: C000002 " \
                          "(record 2))"
        _unforge(h, 3)
        # signed with the forger's own key
        forger = Signer(keys["other"][0])
        hh = _forge_append(h, "00" * 64, forger.key_id)
        _unforge(h, 3)
        _forge_append(h, forger.sign(hh), forger.key_id)
        sig = h.verify_signatures([pub])
        assert sig.first_bad == "I000003 (record 3)"
        assert sig.why == f"signed by key {forger.key_id}, not by the key given ({kid})"
        _unforge(h, 3)
        # a signature copied from another record, under the laboratory's key id
        copied = _rows(h)[-1]["signature"]
        _forge_append(h, copied, kid)
        sig = h.verify_signatures([pub])
        assert sig.first_bad == "I000003 (record 3)"
        assert sig.why == f"its signature does not match its hash under key {kid}"
        _unforge(h, 3)
        _forge_append(h, "not a signature", kid)                # not even hex
        assert h.verify_signatures([pub]).why == ("its signature does not match its hash "
                                                  f"under key {kid}")
        _unforge(h, 3)
        assert h.verify_signatures([pub]).ok


def test_rewritten_history_caught(store_url, history_two, keys):
    """A stored result rewritten and every hash after it recomputed: caught at that record,
    whether its signature is kept, dropped, or every signature is dropped."""
    from sqlalchemy import update

    from volcal.history import schema as t
    from volcal.history.api import History
    from volcal.history.chain import record_hash
    from volcal.history.store import NewRecord

    priv, pub, kid = keys["lab"]
    with History(store_url, private_key=priv) as h:
        a = h.add(history_two["a"], history_two["a"] / "model.json")
        h.store.append(NewRecord("interval", {"interval_days": 180}, machine_id=a.machine_id))
        with h.store.engine.begin() as conn:
            conn.execute(update(t.results).where(t.results.c.record_seq == a.seq,
                                                 t.results.c.name == "X.A")
                         .values(value=t.results.c.value - 1.0))

        def rechain(drop: set[int]) -> None:
            from sqlalchemy import select

            prev = "0" * 64
            with h.store.engine.begin() as conn:
                for r in _rows(h):
                    kids = [[dict(x) for x in conn.execute(select(tbl).where(
                        tbl.c.record_seq == r["seq"])).mappings()]
                        for tbl in (t.files, t.results, t.equipment)]
                    new = record_hash(prev, {**r, "prev_hash": prev}, *kids)
                    vals = {"prev_hash": prev, "hash": new}
                    if r["seq"] in drop:
                        vals.update(signature=None, key_id=None)
                    conn.execute(update(t.records).where(t.records.c.seq == r["seq"])
                                 .values(**vals))
                    prev = new

        rechain(set())
        assert h.verify()[0]                                  # the chain alone is fooled
        sig = h.verify_signatures([pub])
        assert (sig.first_bad, sig.why) == (
            "C000002 (record 2)", f"its signature does not match its hash under key {kid}")
        rechain({2, 3})
        sig = h.verify_signatures([pub])
        assert (sig.first_bad, sig.why) == (
            "C000002 (record 2)", "it is not signed, after signed records (last signed: "
            "M000001 (record 1))")
        rechain({1, 2, 3})
        sig = h.verify_signatures([pub])
        assert not sig.ok and (sig.first_bad, sig.why) == (None, "no record is signed")


def test_unsigned_stores_and_refusals(tmp_path, history_two, keys, monkeypatch):
    """Unsigned records before signing began are vouched for by the first signed one; an
    unsigned add after signed records is refused; VOLCAL_HISTORY_KEY signs."""
    from volcal.history.api import History
    from volcal.history.signing import KEY_ENV, Signer
    from volcal.history.store import NewRecord

    priv, pub, kid = keys["lab"]
    monkeypatch.delenv(KEY_ENV, raising=False)
    db = str(tmp_path / "h.sqlite")
    with History(db) as h:
        a = h.add(history_two["a"], history_two["a"] / "model.json")
        assert a.signature is None and h.verify()[0]
        assert (h.verify_signatures([pub]).why, h.verify_signatures([pub]).ok) == (
            "no record is signed", False)
    monkeypatch.setenv(KEY_ENV, str(priv))
    with History(db) as h:
        b = h.add(history_two["b"], history_two["b"] / "model.json")
        assert b.key_id == kid
        sig = h.verify_signatures([pub])
        assert sig.ok and (sig.signed, sig.n) == (1, 3)
    monkeypatch.delenv(KEY_ENV)
    with History(db) as h:
        # a retried add appends nothing: no key needed
        assert h.add(history_two["b"], history_two["b"] / "model.json").already_stored
        with pytest.raises(VolcalInputError) as exc:
            h.store.append(NewRecord("interval", {"interval_days": 90}, machine_id=b.machine_id))
    assert str(exc.value) == (f"the records of the history sqlite:///{db} are signed (the last, "
                              f"C000003, by key {kid}): give --private-key FILE or set "
                              f"{KEY_ENV} to sign this one")
    with History(db) as h:
        assert len(h.list()) == 3
    # a private key others can read is refused
    loose = tmp_path / "loose.pem"
    loose.write_bytes(priv.read_bytes())
    os.chmod(loose, 0o644)
    with pytest.raises(VolcalInputError) as exc:
        Signer(loose)
    assert str(exc.value) == (f"{loose}: the private key is readable by others (permissions "
                              "0644): chmod 600 it")


def test_migration_keeps_records_unsigned(tmp_path, history_two):
    """A store of revision 0002 upgrades to the head: same records, same hashes, unsigned."""
    import sqlite3

    from sqlalchemy import text

    from volcal.history.api import History
    from volcal.history.engine import HEAD, make_engine, migrate

    url = f"sqlite:///{tmp_path / 'old.sqlite'}"
    eng = make_engine(url)
    migrate(eng, "0002")
    eng.dispose()
    src = f"sqlite:///{history_two['db']}"
    # the records of the shared store (head revision), copied into the 0002 store
    with sqlite3.connect(tmp_path / "old.sqlite") as dst, \
            sqlite3.connect(history_two["db"]) as s:
        for tbl in ("records", "files", "results", "equipment"):
            cols = [c[1] for c in dst.execute(f"PRAGMA table_info({tbl})")]
            rows = s.execute(f"SELECT {', '.join(cols)} FROM {tbl}").fetchall()
            dst.executemany(f"INSERT INTO {tbl} ({', '.join(cols)}) VALUES "
                            f"({', '.join('?' * len(cols))})", rows)
    with History(src) as h0:
        before = [(r.id, r.hash) for r in h0.list()]
    with History(url) as h:
        assert [(r.id, r.hash) for r in h.list()] == before
        assert h.verify()[0] and all(r.signature is None for r in h.list())
        with h.store.engine.connect() as conn:
            assert conn.execute(text("SELECT version_num FROM alembic_version")).scalar() == HEAD
    assert HEAD == "0004"


def _certificate(folder, session_folder, number=None):
    """certificate.json as ``volcal report --certificate`` writes it (no PDF needed)."""
    from volcal.report.certificate import build_certificate
    from volcal.session.format import read_session

    doc = build_certificate(read_session(session_folder), issued="2026-01-12")
    if number is not None:
        doc["report_id"] = number
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "certificate.json").write_text(json.dumps(doc, indent=2) + "\n")
    return doc["report_id"]


def _volcal(*args: str, env: dict | None = None):
    return volcal_process(*args, env=env, timeout=scaled_timeout(300))


def test_certificate_number_stored_shown_found(tmp_path, history_two):
    from volcal.history.api import History

    a, b = history_two["a"], history_two["b"]
    number = _certificate(tmp_path / "ra", a)
    assert number                                          # the derived number
    with History(str(tmp_path / "h.sqlite")) as h:
        with pytest.raises(VolcalInputError) as exc:        # B's readings, A's certificate
            h.add(b, b / "model.json", certificate=tmp_path / "ra")
        assert str(exc.value) == (
            f"{tmp_path / 'ra' / 'certificate.json'}: certificate {number} is of other readings "
            f"than the session {b} (results.as_found.readings_sha256)")
        with pytest.raises(VolcalInputError, match="no certificate.json: --certificate names "
                           "the folder `volcal report --certificate` wrote"):
            h.add(a, a / "model.json", certificate=tmp_path)
    env = {**os.environ, "VOLCAL_DB": str(tmp_path / "h.sqlite")}
    r = _volcal("history", "add", str(a), "--model", str(a / "model.json"), "--certificate",
                str(tmp_path / "ra"), env=env)
    assert r.returncode == 0 and r.stdout == "C000002\n", r.stderr
    _volcal("history", "add", str(b), "--model", str(b / "model.json"), env=env)
    show = _volcal("history", "show", "C000002", env=env).stdout
    assert f"\ncertificate: {number}\n" in show
    assert "\ncertificate:" not in _volcal("history", "show", "C000003", env=env).stdout
    found = json.loads(_volcal("history", "list", "--json", "--certificate", number,
                               env=env).stdout)
    assert [(x["id"], x["report_id"]) for x in found] == [("C000002", number)]
    text_list = _volcal("history", "list", "--certificate", number, env=env).stdout
    assert text_list.splitlines()[1].endswith(f"\tcertificate {number}")
    miss = _volcal("history", "list", "--certificate", "NOPE-1", env=env)
    assert miss.returncode == 1 and "no calibration of certificate 'NOPE-1' in the history" \
        in miss.stderr


def test_cli_sign_and_verify(tmp_path, history_two):
    """key new, add --private-key, verify --public-key: the lines printed and the exit codes."""
    a = history_two["a"]
    env = {**os.environ, "VOLCAL_DB": str(tmp_path / "h.sqlite"),
           "XDG_CONFIG_HOME": str(tmp_path / "cfg")}
    env.pop("VOLCAL_HISTORY_KEY", None)
    k = _volcal("history", "key", "new", env=env)
    priv = tmp_path / "cfg" / "volcal" / "history-key.pem"
    pub = priv.with_name("history-key.pub.pem")
    assert k.returncode == 0 and k.stdout == f"{priv}\n", k.stderr
    assert stat.S_IMODE(priv.stat().st_mode) == 0o600
    again = _volcal("history", "key", "new", env=env)
    assert again.returncode == 2 and "a key is already there" in again.stderr
    typo = _volcal("history", "add", str(a), "--model", str(a / "model.json"),
                   "--private-key", str(priv) + "x", env=env)
    assert typo.returncode == 2 and f"{priv}x: private key file not found" in typo.stderr
    assert not (tmp_path / "h.sqlite").exists()            # refused before the store opened
    assert _volcal("history", "add", str(a), "--model", str(a / "model.json"), "--create",
                   "--private-key", str(priv), env=env).stdout == "C000002\n"
    from volcal.history.signing import load_public_key

    kid = load_public_key(pub)[1]
    assert f"\nsigned by key {kid} " in _volcal("history", "show", "C000002", env=env).stdout
    v = _volcal("history", "verify", "--public-key", str(pub), env=env)
    lines = v.stdout.splitlines()
    assert v.returncode == 0 and lines[0].startswith("chain intact: 2 records; head ")
    assert lines[1] == ("signatures valid: every record up to C000002 (record 2) is vouched "
                        "for by the key (2 of 2 records signed)")
    refused = _volcal("history", "interval", "VMC-1", "100", env=env)
    assert refused.returncode == 2 and "are signed (the last, C000002" in refused.stderr
    from volcal.history.api import History

    with History(env["VOLCAL_DB"]) as h:
        _forge_append(h)
    v = _volcal("history", "verify", "--public-key", str(pub), env=env)
    assert v.returncode == 1 and v.stdout.splitlines()[1] == (
        "signatures BROKEN at I000003 (record 3): it is not signed, after signed records "
        "(last signed: C000002 (record 2))")
    assert _volcal("history", "verify", env=env).returncode == 0   # the chain alone: intact
