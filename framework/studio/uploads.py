"""What the studio accepts as an uploaded drawing, checked before any job exists.

An upload is refused in one sentence when its name has no suffix a reader takes, when it
is larger than the input limit (``INKMOTION_MAX_INPUT_MB``, as ``submit``), when its first
bytes are not what its suffix says (a PNG that is not a PNG, an SVG that is not text), or
when a picture's header declares more pixels than the tracer reads
(:data:`inkmotion.tracing.picture.REFUSE_PIXELS`). The file is then stored under a name made
here: a fixed stem of safe characters and the suffix, so nothing the browser sends
becomes a path.
"""

from __future__ import annotations

import re
import secrets
from pathlib import Path

from inkmotion.errors import InputError

#: the Netpbm family's headers: a .ppm may hold a grey P5 (Pillow writes one)
NETPBM = tuple(b"P%d" % k for k in range(1, 7))
#: the first bytes a picture of these suffixes starts with; a picture suffix not listed
#: here (an AVIF or HEIC photo, whose header is a box of variable size, a PDF page) is
#: judged by its content as the tracer opens it
PICTURE_MAGIC: dict[str, tuple[bytes, ...]] = {
    ".png": (b"\x89PNG\r\n\x1a\n",), ".jpg": (b"\xff\xd8\xff",), ".jpeg": (b"\xff\xd8\xff",),
    ".bmp": (b"BM",), ".webp": (b"RIFF",), ".gif": (b"GIF87a", b"GIF89a"),
    ".tif": (b"II*\x00", b"MM\x00*"), ".tiff": (b"II*\x00", b"MM\x00*"),
    ".pgm": NETPBM, ".ppm": NETPBM,
}


def _kinds() -> dict[str, tuple[str, tuple[bytes, ...]]]:
    """suffix -> (kind, the first bytes it may start with; empty: text, or a picture judged
    by its content): the recorded drawings, and every picture the tracer reads
    (:data:`inkmotion.images.formats.PICTURE_SUFFIXES`)."""
    from inkmotion.images.formats import PICTURE_SUFFIXES as SUFFIXES

    kinds: dict[str, tuple[str, tuple[bytes, ...]]] = {
        ".gml": ("tag", ()), ".json": ("tag", ()), ".xml": ("tag", ()), ".svg": ("svg", ())}
    kinds.update({s: ("picture", PICTURE_MAGIC.get(s, ())) for s in SUFFIXES})
    return kinds


#: suffix -> (kind, the first bytes it may start with), see :func:`_kinds`
KINDS = _kinds()
_SAFE = re.compile(r"[^A-Za-z0-9_-]+")


def accepted() -> str:
    """The accepted suffixes, for the page's file picker and its sentences: not .pdf, which
    the tracer reads only to refuse it with how to export its page as a picture."""
    return ", ".join(sorted(k for k in KINDS if k != ".pdf"))


def safe_name(filename: str) -> str:
    """A file name made from ``filename``: its stem's safe characters (at most 40) and its
    suffix, lower-cased; the suffix must be one of :data:`KINDS`."""
    suffix = Path(filename).suffix.lower()
    if suffix not in KINDS:
        raise InputError(f"{_shown(filename)}: not a drawing the studio reads; give one of "
                         f"{accepted()}.")
    stem = _SAFE.sub("_", Path(filename).stem).strip("_")[:40] or "upload"
    return stem + suffix


def check_upload(filename: str, data: bytes, max_bytes: int) -> str:
    """The stored name of an acceptable upload (see the module docstring), or
    :class:`InputError` with one sentence naming the file and what to do."""
    name = safe_name(filename)
    shown = _shown(filename)
    if len(data) > max_bytes:
        raise InputError(f"{shown}: {len(data) / 2**20:.1f} MB is above the "
                         f"{max_bytes / 2**20:.0f} MB upload limit; send a smaller file.")
    if not data:
        raise InputError(f"{shown}: the file is empty; pick the drawing again.")
    kind, magic = KINDS[Path(name).suffix]
    if magic and not any(data.startswith(m) for m in magic):
        raise InputError(f"{shown}: its content is not a {Path(name).suffix[1:].upper()} "
                         "picture; export it again or pick another file.")
    if kind == "picture":
        _check_pixels(shown, data)
    elif b"\x00" in data[:4096]:
        raise InputError(f"{shown}: not a text file, as a {Path(name).suffix} must be; "
                         "pick the drawing's GML, JSON or SVG file.")
    return name


def _check_pixels(shown: str, data: bytes) -> None:
    """The picture's header read as the tracer reads it (the same sentences)."""
    import io

    from inkmotion.tracing.picture import open_picture

    with open_picture(io.BytesIO(data), shown):
        pass


def store_upload(folder: Path, name: str, data: bytes) -> Path:
    """``data`` written to a fresh folder under ``folder`` as ``name``; its path."""
    target = folder / secrets.token_hex(8) / name
    target.parent.mkdir(parents=True)
    target.write_bytes(data)
    return target


def _shown(filename: str) -> str:
    """The browser's file name as shown in a sentence: printable and short."""
    text = "".join(c for c in filename if c.isprintable())[:80]
    return text or "The upload"
