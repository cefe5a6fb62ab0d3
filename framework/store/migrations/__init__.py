"""Alembic environment and revisions of the job store (run by ``inkmotion.store.db``)."""
