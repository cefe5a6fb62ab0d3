"""``inkmotion view``: open a job's rerun recording in the viewer (or print the command).

Finding the file needs only :data:`inkmotion.recording.RECORDING_NAME` and, for a job id,
the job store; the viewer is a separate process (the ``rerun`` binary), so nothing here
imports torch or the rerun SDK.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.cli.jobs import resolve_job
from inkmotion.errors import InkmotionError, SpecError

out = Console(emoji=False)  # paths are printed as they are


def has_display() -> bool:
    """True where a viewer window can open (X11/Wayland, or macOS/Windows)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def recording_path(target: str) -> Path:
    """The .rrd for ``target``: a file, a results folder, or a job id whose artifacts hold
    one; raises :class:`SpecError` (one sentence) when there is none."""
    from inkmotion.recording import RECORDING_NAME

    p = Path(target)
    if p.is_file() and p.suffix != ".rrd":
        folder = p.parent if (p.parent / RECORDING_NAME).is_file() else None
        raise SpecError(f"{p}: not a recording (a .rrd file); give "
                        + (f"{folder / RECORDING_NAME} or its folder {folder}."
                           if folder is not None else "a run's .rrd file or its folder."))
    if p.suffix == ".rrd" or p.is_file():
        if not p.is_file():
            raise SpecError(f"{p}: no such recording file; check the path.")
        return p.resolve()
    if p.is_dir():
        if (p / RECORDING_NAME).is_file():
            return (p / RECORDING_NAME).resolve()
        raise SpecError(f"{p} holds no {RECORDING_NAME}; give the --out folder of a run "
                        "made with --record (the default), or its .rrd file.")
    if "/" in target or os.sep in target:  # a path (a job id never holds one)
        raise SpecError(f"{p}: no such folder or file; give a results folder, a .rrd file "
                        "or a job id.")
    r = resolve_job(target)
    if r.status != "succeeded" or not r.artifact_dir:
        raise SpecError(f"Job {r.id} is {r.status}; its recording appears when it "
                        "has succeeded (`inkmotion jobs wait` waits for it).")
    rrd = Path(r.artifact_dir) / RECORDING_NAME
    if not rrd.is_file():
        raise SpecError(f"Job {r.id} has no {RECORDING_NAME} in {r.artifact_dir}.")
    return rrd


def view_cmd(
    target: Annotated[str, typer.Argument(help="Job id, results folder or FILE.rrd.")],
    print_only: Annotated[bool, typer.Option(
        "--print", help="Only print the command that opens the viewer.")] = False,
) -> None:
    """Open a job's rerun recording in the viewer (or print the command to run)."""
    try:
        rrd = recording_path(target)
    except InkmotionError as exc:
        fail(exc)
    from inkmotion.recording import rerun_binary

    binary = rerun_binary()
    command = f"{binary or 'rerun'} {rrd}"
    if print_only or not has_display() or binary is None:
        why = "" if print_only else ("no display here; " if binary else
                                     "the rerun viewer is not installed here; ")
        out.print(f"{why}open the recording with:\n  {command}\n"
                  f"or in a browser: {binary or 'rerun'} --web-viewer {rrd}", highlight=False,
                  soft_wrap=True, markup=False)
        return
    subprocess.Popen([binary, str(rrd)], start_new_session=True,
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out.print(f"opened {rrd} in the rerun viewer", highlight=False, markup=False)


def register(app: typer.Typer) -> None:
    """Add ``view`` to the ``inkmotion`` app."""
    app.command("view")(view_cmd)
