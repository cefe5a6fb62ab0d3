"""The inputs that ship with inkmotion, named ``sample:NAME`` wherever an input is accepted.

``inkmotion run fit sample:tempt-1``, ``inkmotion run abstract sample:shapes``,
``inkmotion evaluate PLAN --recording sample:tempt-1``, ``inkmotion benchmark sample:tempt-1
sample:tempt-2``: a job spec keeps the ``sample:NAME`` string (so job.json reproduces on any
installation), and whatever reads the input asks :func:`locate` for the file. The files are
package data of this package, found with :mod:`importlib.resources`; their provenance and
licences are in ``NOTICE.md`` beside them.

Only :mod:`dataclasses` and :mod:`inkmotion.errors` are imported here (importlib.resources
when a file is asked for), so the command line's start-up and the spec checks pay nothing
for it.
"""

from __future__ import annotations

from dataclasses import dataclass

from inkmotion.errors import InputError

#: the scheme of a sample source: ``sample:NAME``
PREFIX = "sample:"
#: the licence of the recorded tags (NOTICE.md has its text)
TAG_LICENCE = "MIT (github:nothub/gml)"
#: the licence of the files made for the project (the project's own)
OWN_LICENCE = "MIT (inkmotion)"


@dataclass(frozen=True)
class Sample:
    """One shipped input: ``name`` (as in ``sample:NAME``), its ``file`` in this package,
    what ``input`` it is, the job ``kinds`` that take it, a one-line ``description`` and
    its ``licence``."""

    name: str
    file: str
    input: str
    kinds: tuple[str, ...]
    description: str
    licence: str


#: every sample, in the order ``inkmotion samples`` lists them
SAMPLES: tuple[Sample, ...] = (
    Sample("tempt-1", "temptTag-2010_6_7_14_52_1.gml", "tag (GML)",
           ("fit", "benchmark", "evaluate --recording"),
           "A recorded graffiti tag: 3 strokes, time-stamped.", TAG_LICENCE),
    Sample("tempt-2", "temptTag-2010_7_28_15_3_5.gml", "tag (GML)",
           ("fit", "benchmark", "evaluate --recording"),
           "A recorded graffiti tag: 5 short strokes, time-stamped.", TAG_LICENCE),
    Sample("tempt-3", "temptTag-2010_7_29_14_58_47.gml", "tag (GML)",
           ("fit", "benchmark", "evaluate --recording"),
           "A recorded graffiti tag: 8 strokes, time-stamped.", TAG_LICENCE),
    Sample("shapes", "shapes.png", "photo (PNG)", ("abstract",),
           "A lit still life, 512 x 384 px: a ball, a cylinder, a box.",
           OWN_LICENCE),
    Sample("spiral", "spiral.svg", "drawing (SVG)", ("fit", "benchmark"),
           "A spiral, a wave and a loop (3 paths).", OWN_LICENCE),
    Sample("brush-scan", "brush-scan.png", "picture (PNG)", ("fit", "benchmark", "trace"),
           "The word 'inkmotion' brushed in script on lit paper, 900 px: line art "
           "to trace.", OWN_LICENCE),
)


def available() -> tuple[Sample, ...]:
    """Every shipped sample (:data:`SAMPLES`)."""
    return SAMPLES


def is_sample(source: str) -> bool:
    """True for ``sample:NAME`` sources (known or not)."""
    return source.startswith(PREFIX)


def find(name: str) -> Sample:
    """The sample called ``name`` (without ``sample:``); an unknown name raises
    :class:`InputError` naming it and listing the known ones."""
    for sample in SAMPLES:
        if sample.name == name:
            return sample
    known = ", ".join(s.name for s in SAMPLES)
    raise InputError(f"{PREFIX}{name}: no such sample; the samples are {known} "
                     "(`inkmotion samples` lists them), or give a file path.")


def path_of(name: str) -> str:
    """The installed file of the sample ``name``; :class:`InputError` when the name is
    unknown or this installation lacks the file (one built without package data)."""
    from importlib.resources import files  # here: it costs start-up (tempfile) otherwise

    sample = find(name)
    resource = files(__name__).joinpath(sample.file)
    if not resource.is_file():
        raise InputError(f"{PREFIX}{name}: this installation of inkmotion lacks the file "
                         f"{sample.file}; reinstall inkmotion (the samples are package data).")
    return str(resource)


def locate(source: str) -> str:
    """The file of a ``sample:NAME`` source (:func:`path_of`); any other source (a path,
    ``text:WORD``) is returned unchanged."""
    return path_of(source[len(PREFIX):]) if is_sample(source) else source
