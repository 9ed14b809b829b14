"""The first schema: records (the chain), their files and results.

Revision ID: 0001
Revises:
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Create records, files, results."""
    op.create_table(
        "records",
        sa.Column("seq", sa.Integer, primary_key=True, autoincrement=False),
        sa.Column("id", sa.String(32), nullable=False, unique=True),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("machine_id", sa.String(32), nullable=True),
        sa.Column("date", sa.String(32), nullable=True),
        sa.Column("created", sa.String(32), nullable=False),
        sa.Column("supersedes", sa.String(32), nullable=True),
        sa.Column("as_left_of", sa.String(32), nullable=True),
        sa.Column("payload", sa.Text, nullable=False),
        sa.Column("prev_hash", sa.String(64), nullable=False),
        sa.Column("hash", sa.String(64), nullable=False, unique=True),
    )
    op.create_table(
        "files",
        sa.Column("record_seq", sa.Integer, sa.ForeignKey("records.seq"), primary_key=True),
        sa.Column("role", sa.String(32), primary_key=True),
        sa.Column("name", sa.String(255), primary_key=True),
        sa.Column("sha256", sa.String(64), nullable=False),
        sa.Column("content", sa.LargeBinary, nullable=False),
    )
    op.create_table(
        "results",
        sa.Column("record_seq", sa.Integer, sa.ForeignKey("records.seq"), primary_key=True),
        sa.Column("name", sa.String(128), primary_key=True),
        sa.Column("value", sa.Float, nullable=True),
        sa.Column("U", sa.Float, nullable=True),
        sa.Column("unit", sa.String(8), nullable=False),
    )


def downgrade() -> None:
    """Drop them."""
    op.drop_table("results")
    op.drop_table("files")
    op.drop_table("records")
