"""The signature of each record's hash (signed records, optional).

Revision ID: 0003
Revises: 0002

Two nullable columns: the records of an existing store stay as they are (unsigned), and
their hashes do not change (the signature is not part of the hash it signs).
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Add records.signature and records.key_id."""
    with op.batch_alter_table("records") as batch:
        batch.add_column(sa.Column("signature", sa.String(128), nullable=True))
        batch.add_column(sa.Column("key_id", sa.String(16), nullable=True))


def downgrade() -> None:
    """Remove them."""
    with op.batch_alter_table("records") as batch:
        batch.drop_column("key_id")
        batch.drop_column("signature")
