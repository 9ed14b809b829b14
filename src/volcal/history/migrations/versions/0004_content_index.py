"""The content digest of each calibration in a column with a unique index; more indexes.

The indexes of one machine's reads: ``machine_id``, ``supersedes``, ``kind``.

Revision ID: 0004
Revises: 0003

``records.content_sha256`` holds the payload's ``content_sha256`` (the readings and the
model, :func:`volcal.history.record.calibration_record`) of every calibration that is not
a correction (``supersedes`` null), null otherwise: the retried add is found by an index,
and the database itself refuses a second record of the same content. Like the signature,
the column is outside the record's hash (the hashes of an existing store do not change);
``verify`` checks that it agrees with the payload.

A store written before volcal refused duplicates can hold the same content twice (issue
26: a retried add appended a second record). Records are never deleted, so such a store
gets the same index *not unique* (``ix_records_content_sha256``) and keeps working: a
retried add still returns the newest of them (the writers' lock serialises the check),
and ``volcal history verify`` names the records that hold the same content.
"""

import json

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None

INDEX = "ix_records_content_sha256"


def _digest(payload) -> str | None:
    """The payload's content digest (None: none, or a payload that does not parse)."""
    try:
        doc = json.loads(payload)
    except (TypeError, ValueError):
        return None
    d = doc.get("content_sha256") if isinstance(doc, dict) else None
    return d if isinstance(d, str) and len(d) <= 64 else None


def upgrade() -> None:
    """Add records.content_sha256 (filled from the payloads) and the indexes."""
    with op.batch_alter_table("records") as batch:
        batch.add_column(sa.Column("content_sha256", sa.String(64), nullable=True))
    conn = op.get_bind()
    rec = sa.table("records", sa.column("seq", sa.Integer), sa.column("kind", sa.String),
                   sa.column("supersedes", sa.String), sa.column("payload", sa.Text),
                   sa.column("content_sha256", sa.String))
    seen: set[str] = set()
    unique = True
    rows = conn.execute(sa.select(rec.c.seq, rec.c.payload).where(
        rec.c.kind == "calibration", rec.c.supersedes.is_(None)).order_by(rec.c.seq)).all()
    for seq, payload in rows:
        digest = _digest(payload)
        if digest is None:
            continue
        unique = unique and digest not in seen
        seen.add(digest)
        conn.execute(sa.update(rec).where(rec.c.seq == seq).values(content_sha256=digest))
    op.create_index(INDEX, "records", ["content_sha256"], unique=unique)
    op.create_index("ix_records_machine_id", "records", ["machine_id"])
    op.create_index("ix_records_supersedes", "records", ["supersedes"])
    op.create_index("ix_records_kind", "records", ["kind"])


def downgrade() -> None:
    """Remove them."""
    for name in ("ix_records_kind", "ix_records_supersedes", "ix_records_machine_id", INDEX):
        op.drop_index(name, "records")
    with op.batch_alter_table("records") as batch:
        batch.drop_column("content_sha256")
