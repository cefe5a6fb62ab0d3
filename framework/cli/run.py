"""``inkmotion run``: execute a job in this process (no services needed).

``inkmotion run KIND INPUT --out DIR [options]`` — one subcommand per job kind, generated
from its declaration (:mod:`inkmotion.cli.kind_commands`); ``inkmotion run --config
job.json --out DIR [options]`` reproduces a previous run (any kind, any spec version): the
group reads the kind from job.json and hands the whole command line to ``run KIND``, so it
takes the same options (``--steps 100`` overrides job.json's steps as with ``run fit
--config``), and an option that kind does not have is one sentence.

``--out`` onto a folder that holds results is refused unless ``--force``
(:func:`inkmotion.outputs.refuse_to_overwrite`), before anything is loaded.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from inkmotion.cli.errors import EXIT_USAGE, fail
from inkmotion.cli.interrupts import EXIT_INTERRUPTED, StopWhenAsked
from inkmotion.cli.kind_commands import IO_PANEL, KindGroup, kind_command, spec_from_options
from inkmotion.errors import InkmotionError
from inkmotion.json_files import dumps

RUN_HELP = """Run a job in this process (no services needed).

Examples:

  inkmotion run fit sample:tempt-1 --out results/tag

  inkmotion run fit text:hello --out results/hello --steps 300 --size 350

  inkmotion run --config results/tag/job.json --out results/again --steps 100
"""

OUT_HELP = "Output folder (required; written whole or not at all)."
FORCE_HELP = ("Replace the results already in --out (a folder a run wrote; never one "
              "holding this command's input or only files of your own).")
RECORD_HELP = "Write recording.rrd (rerun)."
JSON_HELP = "Print report.json instead of the one-line summary."

OutOpt = Annotated[Optional[Path], typer.Option(  # noqa: UP045
    "--out", help=OUT_HELP, rich_help_panel=IO_PANEL)]
ForceOpt = Annotated[bool, typer.Option("--force", help=FORCE_HELP, rich_help_panel=IO_PANEL)]
RecordOpt = Annotated[bool, typer.Option(help=RECORD_HELP, rich_help_panel=IO_PANEL)]
JsonOpt = Annotated[bool, typer.Option("--json", help=JSON_HELP, rich_help_panel=IO_PANEL)]


def execute(spec: Any, out_dir: Path, record: bool, as_json: bool = False,
            force: bool = False) -> None:
    """Run ``spec`` through the job shell with a progress bar, print where results are
    (``as_json``: print report.json to stdout instead; the progress and warnings go to
    stderr either way). Without ``force``, results another run wrote to ``out_dir`` while
    this one ran are not replaced (:func:`inkmotion.jobs.shell.run_job`'s ``replace``)."""
    from inkmotion.jobs.shell import run_job

    try:
        report = run_job(spec, out_dir, [StopWhenAsked()], record=record, progress=True,
                         replace=force)
    except InkmotionError as exc:
        fail(exc)
    except KeyboardInterrupt:
        typer.echo(f"interrupted; nothing was written to {out_dir}", err=True)
        raise typer.Exit(EXIT_INTERRUPTED) from None
    print(dumps(report, str, indent=1) if as_json else summary(report))
    for warning in report.get("warnings") or []:
        typer.secho(f"warning: {warning}", fg="yellow", err=True)
    if not as_json:
        out_dir = Path(report.get("out_dir", out_dir))
        files = sorted(p.name for p in out_dir.iterdir())
        typer.echo(f"results in {out_dir} ({', '.join(files)})")


def summary(report: dict) -> str:
    """One line: wall time, device and the kind's metrics (a NaN, a figure that does not
    apply, left out)."""
    shown = [f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
             for k, v in (report.get("metrics") or {}).items()
             if k != "quality" and not (isinstance(v, float) and not math.isfinite(v))]
    if report.get("quality") == "poor":
        shown.append("quality POOR")
    return (f"done in {report.get('wall_s', 0.0):.1f} s on {report.get('device', '?')}: "
            + ", ".join(shown))


def _run_kind(kind_name: str, inputs: list[str], values: dict[str, Any]) -> None:
    from inkmotion.jobs.kind import resolve
    from inkmotion.outputs import refuse_to_overwrite

    out_dir, record, config = values.pop("out_dir"), values.pop("record"), values.pop("config")
    force, as_json = values.pop("force", False), values.pop("as_json", False)
    if out_dir is None:
        fail("give the output folder: --out DIR.", code=EXIT_USAGE)
    try:
        refuse_to_overwrite(out_dir, force)
        spec = spec_from_options(kind_name, inputs, values, config)
        refuse_to_overwrite(out_dir, force, inputs=spec.inputs.values())
        resolve(spec)
    except InkmotionError as exc:
        fail(exc)
    if config is not None:
        _say_unlike_the_record(config, spec)
    execute(spec, out_dir, record, as_json, force)


def _say_unlike_the_record(config: Path, spec: Any) -> None:
    """A warning for each reason a rerun of ``config`` (a job.json) may not reproduce its
    result (:func:`inkmotion.jobs.shell.unlike_the_record`)."""
    import json

    from inkmotion.jobs.shell import unlike_the_record

    try:
        recorded = json.loads(Path(config).read_text())
    except (OSError, ValueError):
        return
    if isinstance(recorded, dict):
        for said in unlike_the_record(recorded, spec):
            typer.secho(f"warning: {said}", fg="yellow", err=True)


_EXTRA = [
    inspect.Parameter("out_dir", inspect.Parameter.KEYWORD_ONLY, default=None, annotation=OutOpt),
    inspect.Parameter("force", inspect.Parameter.KEYWORD_ONLY, default=False,
                      annotation=ForceOpt),
    inspect.Parameter("record", inspect.Parameter.KEYWORD_ONLY, default=True,
                      annotation=RecordOpt),
    inspect.Parameter("as_json", inspect.Parameter.KEYWORD_ONLY, default=False,
                      annotation=JsonOpt),
]


class RunGroup(KindGroup):
    """``inkmotion run KIND``: one command per job kind (and ``inkmotion run --config
    job.json ...``, see :class:`KindGroup`)."""

    def make(self, kind: Any) -> Any:
        return kind_command(kind, "run", _run_kind, _EXTRA)


run_app = typer.Typer(cls=RunGroup, help=RUN_HELP, no_args_is_help=False,
                      rich_markup_mode="rich")


@run_app.callback(invoke_without_command=True)
def run_main(
    ctx: typer.Context,
    config: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--config", help="A job.json to reproduce; every option of its kind's `run KIND` "
        "applies (e.g. --steps 100 overrides its steps).")] = None,
    out_dir: Annotated[Optional[Path], typer.Option("--out", help=OUT_HELP)] = None,  # noqa: UP045
    force: Annotated[bool, typer.Option("--force", help=FORCE_HELP)] = False,
    record: Annotated[bool, typer.Option(help=RECORD_HELP)] = True,
    as_json: Annotated[bool, typer.Option("--json", help=JSON_HELP)] = False,
) -> None:
    """Run a job in this process. With --config, the options are those of the job's kind
    (the group hands them to ``run KIND``, see :class:`KindGroup`); this callback
    only answers a command line without a kind or a job file."""
    if ctx.invoked_subcommand is not None:
        return
    typer.echo(ctx.get_help(), err=True)
    fail("give a job kind (e.g. `inkmotion run fit INPUT --out DIR`) or --config job.json "
         "--out DIR.", code=EXIT_USAGE)


def register(app: typer.Typer) -> None:
    """Add ``run`` to the ``inkmotion`` app."""
    app.add_typer(run_app, name="run")
