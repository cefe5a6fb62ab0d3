"""The one check that an output the command line was given holds nothing a user would lose.

Every command that takes ``--out`` calls :func:`refuse_to_overwrite` before it loads or
writes anything: a folder that holds results (any entry at all) or an existing file is
refused in one sentence unless ``--force`` was given; a missing path or an empty folder is
fine. The check belongs to the command line, not to the job shell: a worker resuming a job
writes into the job's own folder again, on purpose.
"""

from __future__ import annotations

from pathlib import Path

from inkmotion.errors import InkmotionError

#: the files named first when a results folder is refused (what a run writes that a user
#: recognises); the others follow alphabetically
TELLING = ("report.json", "plan.json", "job.json", "summary.json", "evaluation.json")
#: how many names the sentence lists before "..."
SHOWN = 2


class OutputExistsError(InkmotionError):
    """``--out`` names a folder that holds results, or a file that exists."""


def refuse_to_overwrite(out: Path, force: bool, *, folder: bool = True) -> None:
    """Raise :class:`OutputExistsError` (one sentence) when writing ``out`` would replace
    something a user has: a non-empty folder (``folder``: the command writes a folder) or
    an existing file (``folder=False``: it writes one file), unless ``force``. A path of
    the other sort (a file where a folder goes, or the reverse) is refused even with
    ``force``: replacing it is never what was meant."""
    out = Path(out)
    if folder and out.exists() and not out.is_dir():
        raise OutputExistsError(f"{out} is a file, not a folder; choose another --out.")
    if not folder and out.is_dir():
        raise OutputExistsError(f"{out} is a folder; give a file name with --out.")
    if force or not out.exists():
        return
    if not folder:
        raise OutputExistsError(f"{out} already exists; pass --force to replace it, or "
                                "choose another --out.")
    names = [p.name for p in out.iterdir()]
    if not names:
        return
    order = {name: i for i, name in enumerate(TELLING)}
    names.sort(key=lambda n: (order.get(n, len(TELLING)), n))
    listed = ", ".join(names[:SHOWN]) + (", ..." if len(names) > SHOWN else "")
    raise OutputExistsError(f"{out} already holds results ({listed}); pass --force to "
                            "replace them, or choose another --out.")
