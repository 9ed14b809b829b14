"""The equipment of each calibration and the certificate's report id.

Revision ID: 0002
Revises: 0001
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Add the equipment table and records.report_id."""
    op.create_table(
        "equipment",
        sa.Column("record_seq", sa.Integer, sa.ForeignKey("records.seq"), primary_key=True),
        sa.Column("position", sa.Integer, primary_key=True),
        sa.Column("role", sa.String(64), nullable=False),
        sa.Column("make", sa.String(128), nullable=True),
        sa.Column("model", sa.String(128), nullable=True),
        sa.Column("serial", sa.String(128), nullable=True),
        sa.Column("certificate", sa.String(128), nullable=True),
        sa.Column("calibrated", sa.String(32), nullable=True),
        sa.Column("due", sa.String(32), nullable=True),
    )
    with op.batch_alter_table("records") as batch:
        batch.add_column(sa.Column("report_id", sa.String(64), nullable=True))


def downgrade() -> None:
    """Remove them."""
    with op.batch_alter_table("records") as batch:
        batch.drop_column("report_id")
    op.drop_table("equipment")
