"""The one check that an output the command line was given holds nothing a user would lose.

Every command that takes ``--out`` calls :func:`refuse_to_overwrite` before it loads or
writes anything: a folder that holds results (any entry at all) or an existing file is
refused in one sentence unless ``--force`` was given; a missing path or an empty folder is
fine. ``--force`` replaces a folder of results only (one holding a file a run writes,
:data:`RESULTS`), and never a folder that holds the command's own input (a plan plotted
into its fit's folder would be deleted before it is read). The check belongs to the
command line, not to the job shell: a worker resuming a job writes into the job's own
folder again, on purpose.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from inkmotion.errors import InkmotionError

#: the files named first when a results folder is refused (what a run writes that a user
#: recognises); the others follow alphabetically
TELLING = ("report.json", "plan.json", "job.json", "summary.json", "evaluation.json")
#: how many names the sentence lists before "..."
SHOWN = 2
#: files that mark a folder as inkmotion's results, which ``--force`` may replace: a
#: job's (run), a benchmark's and a trace's
RESULTS = ("job.json", "report.json", "summary.json", "extraction.json")


class OutputExistsError(InkmotionError):
    """``--out`` names a folder that holds results, or a file that exists."""


def refuse_to_overwrite(out: Path, force: bool, *, folder: bool = True,
                        inputs: Iterable[str | Path] = ()) -> None:
    """Raise :class:`OutputExistsError` (one sentence) when writing ``out`` would replace
    something a user has: a non-empty folder (``folder``: the command writes a folder) or
    an existing file (``folder=False``: it writes one file), unless ``force``. A path of
    the other sort (a file where a folder goes, or the reverse) is refused even with
    ``force``: replacing it is never what was meant; so is a folder that holds one of the
    files ``inputs`` the command reads, or one that holds no results (:data:`RESULTS`)."""
    out = Path(out)
    if folder and out.exists() and not out.is_dir():
        raise OutputExistsError(f"{out} is a file, not a folder; choose another --out.")
    if folder and _within(Path.cwd(), out, file=False):
        raise OutputExistsError(f"--out {out} is the folder you are in (or holds it), which "
                                "the results would replace; give a new folder, e.g. --out "
                                "results.")
    if not folder and out.is_dir():
        raise OutputExistsError(f"{out} is a folder; give a file name with --out.")
    if not out.exists():
        return
    if not folder:
        if not force:
            raise OutputExistsError(f"{out} already exists; pass --force to replace it, or "
                                    "choose another --out.")
        return
    names = [p.name for p in out.iterdir()]
    if not names:
        return
    inside = [str(p) for p in inputs if _within(Path(p), out)]
    if inside:
        raise OutputExistsError(f"{out} holds this command's input {inside[0]}, which "
                                "writing the results there would delete; choose another "
                                "--out.")
    order = {name: i for i, name in enumerate(TELLING)}
    names.sort(key=lambda n: (order.get(n, len(TELLING)), n))
    listed = ", ".join(names[:SHOWN]) + (", ..." if len(names) > SHOWN else "")
    if force and not set(names) & set(RESULTS):
        raise OutputExistsError(f"{out} holds files that are not inkmotion's results "
                                f"({listed}), which --force would delete; choose another "
                                "--out.")
    if not force:
        raise OutputExistsError(f"{out} already holds results ({listed}); pass --force to "
                                "replace them, or choose another --out.")


def _within(path: Path, folder: Path, file: bool = True) -> bool:
    """Whether ``path`` (an existing file, or with ``file=False`` any path) is ``folder``
    or lies in it (at any depth)."""
    try:
        return (not file or path.is_file()) and path.resolve().is_relative_to(
            folder.resolve())
    except OSError:
        return False
