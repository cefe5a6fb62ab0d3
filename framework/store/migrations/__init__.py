"""Alembic environment and revisions of the job store (run by ``inkmotion.store.db``).

:data:`HEAD_REVISION` names the newest revision in ``versions/`` so that
:func:`inkmotion.store.db.get_engine` can tell an up-to-date database from a stale one
with one ``SELECT`` and without importing Alembic (about 0.25 s of start-up per process).
``tests/test_store.py`` asserts it equals the head Alembic computes, so it cannot drift:
bump it in the same change that adds a revision.
"""

HEAD_REVISION = "0003"
