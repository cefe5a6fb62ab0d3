"""The one way the command line reports a user's error: one sentence on stderr, an exit code.

Every command uses :func:`fail`, and the last guard in :func:`inkmotion.cli.main.main` uses
:func:`report`, so no :class:`~inkmotion.errors.InkmotionError` ever shows a traceback and
every error line looks the same. Only typer is imported here: this module is on the start-up
path of every command.
"""

from __future__ import annotations

import sys
from typing import NoReturn

import typer

EXIT_USER = 1  # a user error: bad input, unknown job, unreachable service
EXIT_USAGE = 2  # the command line itself is wrong (as click reports usage errors)
EXIT_TIMEOUT = 3  # `jobs wait` ran out of time


def report(exc: BaseException | str) -> None:
    """Print ``error: <sentence>`` on stderr (the label in bold red on a terminal)."""
    label = typer.style("error:", fg="red", bold=True) if sys.stderr.isatty() else "error:"
    typer.echo(f"{label} {exc}", err=True)


def fail(exc: BaseException | str, code: int = EXIT_USER) -> NoReturn:
    """Print ``error: <sentence>`` on stderr and exit with ``code`` (:data:`EXIT_USER`,
    :data:`EXIT_USAGE` or :data:`EXIT_TIMEOUT`)."""
    report(exc)
    raise typer.Exit(code)
