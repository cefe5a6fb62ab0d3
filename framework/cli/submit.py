"""``inkmotion submit KIND``: queue jobs for the workers (Celery on Redis).

One subcommand per job kind, generated from its declaration like ``run KIND``, so a job
submitted to the workers is exactly the job ``run`` would execute. ``--batch-words FILE``
queues one job per word (``text:WORD``), ``--batch-dir DIR`` one per file. Everything is
validated before anything is queued; a broker that does not answer is one sentence.

Cost: validation imports no torch; checking the broker and publishing imports Celery and
kombu (about half a second), which is most of what ``submit`` takes.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from inkmotion.cli.errors import fail
from inkmotion.cli.kind_commands import IO_PANEL, KindGroup, kind_command, spec_from_options
from inkmotion.errors import InkmotionError, SpecError

SUBMIT_HELP = """Queue jobs for the workers; prints the job id(s).

Examples:

  inkmotion submit fit text:hello --steps 200

  inkmotion submit fit --batch-words words.txt --json

  inkmotion submit fit --batch-dir tags/ && inkmotion jobs list
"""


def batch_inputs(batch_words: Path | None, batch_dir: Path | None) -> list[str]:
    """Inputs of a batch: ``text:WORD`` per line of a word list, or every file of a folder."""
    if batch_words is not None:
        try:
            lines = batch_words.read_text(encoding="utf-8").splitlines()
        except OSError as exc:
            raise SpecError(f"{batch_words}: cannot read the word list ({exc.strerror}).") \
                from exc
        words = [w.strip() for w in lines if w.strip() and not w.strip().startswith("#")]
        if not words:
            raise SpecError(f"{batch_words}: the word list is empty; put one word per line.")
        return [f"text:{w}" for w in words]
    assert batch_dir is not None
    if not batch_dir.is_dir():
        raise SpecError(f"{batch_dir}: no such folder; check the path.")
    files = sorted(p for p in batch_dir.iterdir() if p.is_file() and not p.name.startswith("."))
    if not files:
        raise SpecError(f"{batch_dir}: the folder holds no input files.")
    return [str(p) for p in files]


def _submit_kind(kind_name: str, inputs: list[str], values: dict[str, Any]) -> None:
    from inkmotion.workers.submit import submit_specs

    batch_words, batch_dir = values.pop("batch_words"), values.pop("batch_dir")
    as_json, config = values.pop("as_json"), values.pop("config")
    if sum(x is not None and x != [] for x in (inputs or None, batch_words, batch_dir)) > 1:
        fail("Give one of INPUT, --batch-words or --batch-dir, not several.", code=2)
    try:
        if batch_words is not None or batch_dir is not None:
            specs = [spec_from_options(kind_name, [item], values, config)
                     for item in batch_inputs(batch_words, batch_dir)]
        else:
            if not inputs and config is None:
                fail("Give an INPUT (a file, sample:NAME or text:WORD), --config, "
                     "--batch-words or --batch-dir.", code=2)
            specs = [spec_from_options(kind_name, inputs, values, config)]
        records = submit_specs(specs)
    except InkmotionError as exc:
        fail(exc)
    if as_json:
        typer.echo(json.dumps([{"id": r.id, "input": r.label, "kind": r.kind, "queue": r.queue,
                                "status": r.status} for r in records], indent=1))
        return
    for r in records:
        typer.echo(r.id)
    follow = records[0].id if len(records) == 1 else "ID"
    typer.echo(f"queued {len(records)} job{'s' * (len(records) != 1)} on "
               f"{records[0].queue}; follow with `inkmotion jobs wait {follow}`", err=True)


def _parameter(name: str, annotation: Any, default: Any = None) -> inspect.Parameter:
    return inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default,
                             annotation=annotation)


_EXTRA = [
    _parameter("batch_words", Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--batch-words", help="A .txt file of words, one per line: one text:WORD job each.",
        rich_help_panel=IO_PANEL)]),
    _parameter("batch_dir", Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--batch-dir", help="A folder of inputs: one job per file.",
        rich_help_panel=IO_PANEL)]),
    _parameter("as_json", Annotated[bool, typer.Option(
        "--json", help="Print the jobs as JSON.", rich_help_panel=IO_PANEL)], False),
]


class SubmitGroup(KindGroup):
    """``inkmotion submit KIND``: one command per job kind."""

    def make(self, kind: Any) -> Any:
        return kind_command(kind, "submit", _submit_kind, _EXTRA)


submit_app = typer.Typer(cls=SubmitGroup, help=SUBMIT_HELP, no_args_is_help=True,
                         rich_markup_mode="rich")


def register(app: typer.Typer) -> None:
    """Add ``submit`` to the ``inkmotion`` app."""
    app.add_typer(submit_app, name="submit")
