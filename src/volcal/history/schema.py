"""Tables of the calibration history (SQLAlchemy Core; the migrations create them).

Every row belongs to one *record* of the chain (``records``): a machine, a calibration,
a correction that supersedes one of them, an interval. Records are appended, never
updated or deleted; the children of a record (``files``, ``results``, ``equipment``)
are written in the same transaction and enter its hash (:mod:`volcal.history.chain`).

The schema is created and upgraded by the Alembic revisions in
``volcal/history/migrations/versions`` (``0001`` the records, files and results;
``0002`` the equipment of each calibration and the certificate's report id; ``0003`` the
signature of each record's hash, :mod:`volcal.history.signing`; ``0004`` the content
digest of each calibration with a unique index, and the indexes of one machine's reads).
These
table objects describe the head revision; a test checks that they agree.
"""

from __future__ import annotations

from sqlalchemy import (
    Column,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    MetaData,
    String,
    Table,
    Text,
)

metadata = MetaData()

records = Table(
    "records", metadata,
    Column("seq", Integer, primary_key=True, autoincrement=False),
    Column("id", String(32), nullable=False, unique=True),
    Column("kind", String(16), nullable=False),          # machine, calibration, interval
    Column("machine_id", String(32), nullable=True),     # the machine record it belongs to
    Column("date", String(32), nullable=True),           # of measurement, ISO 8601
    Column("created", String(32), nullable=False),       # UTC time of insertion
    Column("supersedes", String(32), nullable=True),     # id of the record it corrects
    Column("as_left_of", String(32), nullable=True),     # as-found record it pairs with
    Column("payload", Text, nullable=False),             # canonical JSON
    Column("prev_hash", String(64), nullable=False),
    Column("hash", String(64), nullable=False, unique=True),
    Column("report_id", String(64), nullable=True),      # revision 0002
    Column("signature", String(128), nullable=True),     # revision 0003: Ed25519, hex
    Column("key_id", String(16), nullable=True),         # revision 0003: of the signing key
    # revision 0004: the payload's content_sha256 of a calibration that is no correction
    # (outside the hash, checked against the payload by verify)
    Column("content_sha256", String(64), nullable=True),
    # not unique in a store that held duplicates before 0004 (the migration says why)
    Index("ix_records_content_sha256", "content_sha256", unique=True),
    Index("ix_records_machine_id", "machine_id"),
    Index("ix_records_supersedes", "supersedes"),
    Index("ix_records_kind", "kind"),
)

files = Table(
    "files", metadata,
    Column("record_seq", Integer, ForeignKey("records.seq"), primary_key=True),
    Column("role", String(32), primary_key=True),        # session, model, model-binary, ...
    Column("name", String(255), primary_key=True),       # path relative to its folder
    Column("sha256", String(64), nullable=False),
    Column("content", LargeBinary, nullable=False),
)

results = Table(
    "results", metadata,
    Column("record_seq", Integer, ForeignKey("records.seq"), primary_key=True),
    Column("name", String(128), primary_key=True),       # e.g. "X.A", "linear-x1.R", "E_VXYZ"
    Column("value", Float, nullable=True),
    Column("U", Float, nullable=True),                   # expanded uncertainty, k in payload
    Column("unit", String(8), nullable=False),
)

equipment = Table(                                       # revision 0002
    "equipment", metadata,
    Column("record_seq", Integer, ForeignKey("records.seq"), primary_key=True),
    Column("position", Integer, primary_key=True),
    Column("role", String(64), nullable=False),
    Column("make", String(128), nullable=True),
    Column("model", String(128), nullable=True),
    Column("serial", String(128), nullable=True),
    Column("certificate", String(128), nullable=True),
    Column("calibrated", String(32), nullable=True),
    Column("due", String(32), nullable=True),
)

TABLES = ("records", "files", "results", "equipment")
