"""A generic ``metrics`` column: each job kind's summary figures as one JSON object.

The job system runs several kinds (fit, tag, abstract, simulate, evaluate, third-party),
so per-kind figures (e.g. ``{"chamfer_mean_px": 0.12, "t_end_ratio": 0.14}``) go into one
nullable JSON column instead of new fit-specific columns. Existing rows get NULL.

Revision ID: 0002
Revises: 0001
Create Date: 2025-02-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Add ``jobs.metrics`` (nullable JSON); a plain ``ADD COLUMN`` on every backend."""
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("metrics", sa.JSON(), nullable=True))


def downgrade() -> None:
    """Drop ``jobs.metrics``; batch mode copies the table on SQLite, keeping the rows."""
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("metrics")
