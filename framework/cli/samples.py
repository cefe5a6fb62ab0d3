"""``inkmotion samples``: the inputs that ship with inkmotion, used as ``sample:NAME``.

The list is :data:`inkmotion.samples.SAMPLES` (no torch, nothing read), so the command
starts as fast as ``--help``.
"""

from __future__ import annotations

import json
from typing import Annotated, Any, Optional

import typer
from rich.console import Console
from rich.table import Table

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError

out = Console()


def _record(sample: Any) -> dict[str, Any]:
    """One sample as ``--json`` prints it: its fields, its source string and its file's path
    (None where this installation lacks the file)."""
    from dataclasses import asdict

    from inkmotion.samples import PREFIX, path_of

    try:
        path: str | None = path_of(sample.name)
    except InkmotionError:
        path = None
    return {"source": PREFIX + sample.name, **asdict(sample), "path": path}


def samples_cmd(
    path: Annotated[Optional[str], typer.Option(  # noqa: UP045
        "--path", metavar="NAME",
        help="Print only the file of the sample NAME, e.g. cp $(inkmotion samples --path "
             "tempt-1) my-tag.gml.", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List the inputs that ship with inkmotion: give one as sample:NAME wherever an input
    is accepted.

    The tags are real recorded graffiti tags with time stamps (MIT, github:nothub/gml); the
    photo and the SVG were made for inkmotion. NOTICE.md beside the files gives their
    provenance and licences.

    Examples:

      inkmotion samples

      inkmotion run fit sample:tempt-1 --out results/tempt-1

      inkmotion run abstract sample:shapes --out results/shapes

      cp "$(inkmotion samples --path spiral)" my-drawing.svg
    """
    from inkmotion.samples import PREFIX, available, path_of

    if path is not None:
        try:
            print(path_of(path.removeprefix(PREFIX)))
        except InkmotionError as exc:
            fail(exc)
        return
    if as_json:
        print(json.dumps([_record(s) for s in available()], indent=1))
        return
    table = Table(box=None, pad_edge=False, header_style="bold underline")
    table.add_column("sample", no_wrap=True)  # what an input takes: kept whole
    table.add_column("input")
    table.add_column("description")
    table.add_column("licence")
    for s in available():
        table.add_row(f"{PREFIX}{s.name}", s.input, s.description, s.licence)
    out.print(table)
    out.print("The tags and the SVG are inputs of fit and benchmark (the tags also of "
              "evaluate --recording), the photo of abstract. inkmotion samples --path NAME "
              "prints a file's path; NOTICE.md beside the files gives their provenance and "
              "licences.", highlight=False)


def register(app: typer.Typer) -> None:
    """Add ``samples`` to the ``inkmotion`` app."""
    app.command("samples")(samples_cmd)
