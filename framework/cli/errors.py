"""The one way the command line reports a user's error: one sentence on stderr, an exit code.

Every command uses :func:`fail`; no traceback is ever shown for an
:class:`~inkmotion.errors.InkmotionError`.
"""

from __future__ import annotations

import sys
from typing import NoReturn

import typer


def fail(exc: BaseException | str, code: int = 1) -> NoReturn:
    """Print ``error: <sentence>`` on stderr and exit with ``code`` (1: user error,
    2: usage, 3: a wait that timed out)."""
    label = typer.style("error:", fg="red", bold=True) if sys.stderr.isatty() else "error:"
    typer.echo(f"{label} {exc}", err=True)
    raise typer.Exit(code)
