"""Leases: a running job's ``lease_owner`` (the attempt holding it) and ``lease_until``.

A running attempt renews its lease by heartbeats; any worker's reaper puts a job whose
lease expired back on the queue with one conditional update (the attempt's worker died),
so a dead worker's job runs again within a minute instead of after the broker's
visibility timeout. Existing rows get NULL (no lease: a running row from before this
revision may be taken over by the next attempt).

Revision ID: 0003
Revises: 0002
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Add ``jobs.lease_owner`` and ``jobs.lease_until`` (nullable); index the latter."""
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("lease_owner", sa.String(96), nullable=True))
        batch.add_column(sa.Column("lease_until", sa.DateTime(timezone=True), nullable=True))
        batch.create_index("ix_jobs_lease_until", ["lease_until"])


def downgrade() -> None:
    """Drop the lease columns (batch mode copies the table on SQLite, keeping the rows)."""
    with op.batch_alter_table("jobs") as batch:
        batch.drop_index("ix_jobs_lease_until")
        batch.drop_column("lease_until")
        batch.drop_column("lease_owner")
