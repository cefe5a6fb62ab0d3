"""A picture of a line drawing as an ink map: how dark each pixel is against its paper.

Steps, each refusing bad input in one sentence (:class:`~inkmotion.errors.InputError`):

1. **Decode** with Pillow: the pixel count is read from the header first, so a huge
   image is reduced while it is decoded (JPEG draft mode, else ``Image.reduce``) to at
   most :data:`WORK_PIXELS`, or refused above :data:`REFUSE_PIXELS`; a truncated file or
   one that is not an image is refused. Alpha is composited over white paper (black
   under light strokes: a white logo on a transparent background), palettes and CMYK
   converted, 16-bit and float greys scaled to [0, 1]; a photo whose EXIF
   orientation says it is stored turned or mirrored (a phone's portrait photo) is turned
   upright, as every viewer shows it, so its strokes run the way the user sees them.
   Colour is read as luminance; where that shows no ink on the page (a yellow marker),
   the picture is read again from each pixel's darkest colour channel (:data:`TONES`).
2. **The page in a photo** of one lying on a desk (:mod:`inkmotion.tracing.page`): found,
   what lies round it is no ink (said in the notes), and the next steps look at the
   page alone (its tones for the polarity, its bounds for a ruling): a light page with
   dark ink on it, or a dark page on a lighter desk with light ink on it (white ink on
   black paper: a light page in the inverted picture).
3. **Polarity**: the paper is what most of the page is (its median grey), and the ink is
   the side of it the page's extremes reach further into: its darkest and lightest
   :data:`TAIL` (a dim photo of black ink on grey paper is still dark ink; chalk on a
   blackboard is light ink). Where neither side is clearly further (too little ink to
   tell), a page whose median grey is below ½ is light ink on dark paper. The extremes
   are read with the grain calmed (a dim photo's noise reaches above its paper as far
   as below). Light ink is inverted (``invert=True`` forces it).
4. **Flat paper**: uneven light and paper shade are divided out by an estimate of the
   paper itself: the grey image, its grain calmed by a 5 × 5 median, closed (max then
   min) over a window wider than any stroke; the ink is then 1 − grey / paper, in
   [0, 1]. Both keep the paper's own edges (a hard shadow across the page, the edge of a
   photographed page) where they are: a blur spills an edge's bright side into its dark
   side, read as a line of ink along it. (Where a hard shadow's edge meets the picture's
   border at a sharp angle, the closing still fills the shadow's narrow tip: a short
   false stroke ends there.)
5. **Ink mask**: Otsu's threshold of that darkness (never below :data:`MIN_CONTRAST`, so a
   blank page stays blank; a grainy picture, a dim photo's, calmed first: :data:`GRAINY`),
   burrs and notches of JPEG noise evened out (:func:`_tidy`,
   which keeps a line one pixel wide whole), small specks removed and pin-holes filled
   (:mod:`skimage.morphology`). The printed lines of ruled or squared paper are taken
   out (:mod:`inkmotion.tracing.ruling`), and so is a stripe flush with one side of the
   picture along most of it, no thicker than a stroke and touching no other ink
   (:func:`drop_edge_stripes`): the edge of the page or a scanner's shadow. Both are
   said in the notes. A stroke that runs along the edge and leaves it (a T's bar cropped
   to the ink) is kept.
6. **Ink level**: how dark the ink itself is (no ink is black: a marker on paper reads
   about 0.85), the median darkness of the mask's solid core, the pixels at least
   :data:`SOLID_DEPTH` px inside it (out of a scan's blur); 1 when the strokes are too thin
   to have one. A fit renders ink as 1, so it compares its rendering with the darkness
   divided by this level (:attr:`Picture.target`): against the raw darkness a width the
   fit may change (``--varying-width``) would shrink by the level to match the ink's mass.

Refused: a blank page, a page that is mostly ink, and a photo that is not line art (more
half-tones than ink, or its ink too wide for the page: wider than a pen's, and not long
for its width as a broad brush's strokes are).
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from inkmotion.errors import InputError
from inkmotion.geometry.input_file import checked_input_file
from inkmotion.images.formats import PICTURE_FORMATS, PICTURE_SUFFIXES
from inkmotion.tracing.page import find_page
from inkmotion.tracing.ruling import drop_ruling

#: the ISO media brands of a HEIF file's 'ftyp' box (an iPhone's photos), which Pillow
#: reads only through pillow-heif
HEIF_BRANDS = (b"heic", b"heix", b"hevc", b"hevx", b"heim", b"heis", b"mif1", b"msf1")
#: larger images are reduced to about this many pixels as they are decoded (said in notes)
WORK_PIXELS = 4_000_000
#: how a huge picture's pixels are averaged as it is reduced (:func:`_reduced`): as
#: tones, and with alpha premultiplied (any other mode as it is)
AVERAGED_AS = {"1": "L", "P": "RGBA", "PA": "RGBA", "LA": "La", "RGBA": "RGBa",
               "I;16": "I", "I;16B": "I", "I;16L": "I", "I;16N": "I"}
#: rows of a huge picture converted and reduced at a time (:func:`_reduced`)
BAND_ROWS = 512
#: larger images are refused (a decompression bomb, or a page scanned far too fine)
REFUSE_PIXELS = 400_000_000
#: a picture file may be this large: what is limited is its pixel count (REFUSE_PIXELS)
PICTURE_FILE_BYTES = 4 * 2**30
#: what a colour picture is read as: its luminance, or where that shows no ink (a yellow
#: marker is nearly as light as white paper), each pixel's darkest colour channel (for
#: dark ink; its lightest for light ink on dark paper)
TONES = ("grey", "darkest", "lightest")
#: the least darkness, against the paper, that counts as ink
MIN_CONTRAST = 0.18
#: share of the page, at each end of its tones, whose distance from the median tells
#: which side of the paper the ink is (step 3)
TAIL = 0.005
#: σ (px) of the Gaussian that calms grain and JPEG noise before half-tones are measured
DENOISE = 1.0
#: a picture whose ink threshold is less than this many times its paper's grain
#: (:func:`grain`) is calmed (σ :data:`DENOISE`) before the ink is told from the paper:
#: raw, its strokes' outlines are ragged with noise and their skeletons split into spurs
GRAINY = 6.0
#: a page with more ink than this share is not line art
MAX_INK_SHARE = 0.35
#: pixels at least this far (px) inside the ink mask are solid ink, out of reach of a
#: scan's blur (σ up to about 1.5 px)
SOLID_DEPTH = 3.0
#: with fewer solid pixels than this the strokes are too thin to show the ink's own level
SOLID_LEAST = 50
#: ink whose widest strokes (95th percentile) are more than this share of the page's
#: longer side is not line art (:func:`widest_stroke`) ...
MAX_WIDTH_SHARE = 0.05
#: ... though strokes this wide (px) are line art on any page, however small (an icon, a
#: character of a handwriting set at 105 px, whose crossings merge into wider ink)
LEAST_WIDEST = 10.0
#: ... and so is a broad brush's dark ink up to :data:`BRUSH_SHARE` of the longer side,
#: when its pieces run on for at least :data:`BRUSH_LENGTH` of their widths
#: (:func:`_brush_ink`): a calligrapher's character or a marker's letters, where blots, a
#: silhouette or a photo's dark things are about as wide as they are long (three 30-px
#: discs: 0.8; a blotchy photo: 1.2; a brush's 永 at 7 % of the page: 7.3, 心: 5.0). Ink
#: found light on its own is held to a pen's width: a page on a dark desk, read as light
#: ink, is a light block cut by its drawing's lines.
BRUSH_SHARE = 0.1
BRUSH_LENGTH = 4.0
#: ink flush with a side of the picture without a break over at least this share of it is
#: a stripe along the edge (step 5), when it is no thicker than a stroke and alone
EDGE_RUN_SHARE = 0.6


@dataclass
class Picture:
    """A decoded picture: ``grey`` (H, W) in [0, 1], 1 = paper, after polarity; ``ink``
    (H, W) darkness against the flattened paper, [0, 1]; ``mask`` (H, W) bool, the ink
    after clean-up. ``scale`` is the decoded size over the file's (1 unless reduced);
    ``notes`` say what was done that a user should know (reduced, inverted);
    ``ink_level`` the darkness of solid ink (module docstring, step 6); ``page`` the page
    found in a photo (step 2); ``ruling`` the bands of the paper's ruled lines taken out
    of the mask (step 5)."""

    source: str
    grey: np.ndarray
    ink: np.ndarray
    mask: np.ndarray
    scale: float = 1.0
    inverted: bool = False
    notes: list[str] = field(default_factory=list)
    ink_level: float = 1.0
    #: the page found in a photo of one on a desk (H, W) bool, None where none was
    page: np.ndarray | None = None
    #: the bands of the paper's ruled lines (H, W) bool, None on plain paper
    ruling: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.mask.shape  # type: ignore[return-value]

    @property
    def target(self) -> np.ndarray:
        """What a fit's rendering (ink = 1) is compared with: the darkness over the ink
        level, within the mask, float32 (H, W) in [0, 1]."""
        return (np.clip(self.ink / self.ink_level, 0.0, 1.0) * self.mask).astype(np.float32)


def is_picture(source: str) -> bool:
    """True for a path with a picture's suffix
    (:data:`~inkmotion.images.formats.PICTURE_SUFFIXES`)."""
    return Path(source).suffix.lower() in PICTURE_SUFFIXES


@contextlib.contextmanager
def open_picture(file: str | BinaryIO, shown: str) -> Iterator[Any]:
    """The picture ``file`` (a path, or a file object of its bytes) opened by Pillow with its
    header read: an :class:`InputError` naming ``shown`` for a file that is not a picture,
    one that cannot be decoded (truncated, damaged; also when the ``with`` body fails to
    decode it) and one whose header declares more than :data:`REFUSE_PIXELS` (the bomb
    check is this limit, read from the header before any pixel is decoded)."""
    from PIL import Image, UnidentifiedImageError

    head = _head(file)
    if head.startswith(b"%PDF"):
        raise InputError(f"{shown}: a PDF, not a picture; export its page as PNG or JPEG "
                         "(with `pdftoppm -png -r 300 FILE page`, say) and give that.")
    if head[4:8] == b"ftyp" and head[8:12] in HEIF_BRANDS:
        _register_heif(shown)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            Image.MAX_IMAGE_PIXELS = None  # our own limit below, from the header
            with Image.open(file) as img:
                w, h = img.size
                if w * h > REFUSE_PIXELS:
                    raise InputError(
                        f"{shown}: {w} × {h} is {w * h / 1e6:.0f} megapixels, more than the "
                        f"{REFUSE_PIXELS / 1e6:.0f} this reads; scan or export it smaller.")
                yield img
    except InputError:
        raise
    except UnidentifiedImageError:
        raise InputError(f"{shown}: not a picture this can read ({PICTURE_FORMATS}); "
                         "check the file.") from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise InputError(f"{shown}: the picture cannot be decoded ({_reason(exc)}); it may be "
                         "truncated or damaged, so export it again.") from None


def _head(file: str | BinaryIO) -> bytes:
    """The file's first 12 bytes, by which a PDF or a HEIF photo is known whatever its
    name (b"" when it cannot be read: Pillow's open then says why); a file object's
    position is kept."""
    try:
        if isinstance(file, str):
            with open(file, "rb") as f:
                return f.read(12)
        at = file.tell()
        head = file.read(12)
        file.seek(at)
        return head
    except OSError:
        return b""


def _register_heif(shown: str) -> None:
    """Let Pillow read HEIF through pillow-heif, or refuse the photo ``shown`` in one
    sentence when that plugin is not installed."""
    try:
        import pillow_heif  # type: ignore[import-not-found]
    except ImportError:
        raise InputError(f"{shown}: a HEIC/HEIF photo (an iPhone's default format) cannot be "
                         "read without the pillow-heif package; export it as JPEG or PNG, or "
                         "`pip install pillow-heif`.") from None
    pillow_heif.register_heif_opener()


def decode(source: str, tone: str = "grey") -> tuple[np.ndarray, float, list[str]]:
    """Grey (H, W) float32 in [0, 1] of the picture file ``source`` (a colour picture's
    ``tone``, :data:`TONES`), the decoded size over the file's, and notes (module
    docstring, step 1)."""
    from PIL import Image

    from inkmotion.images.orientation import orientation_of, upright

    notes: list[str] = []
    with open_picture(source, source) as img:
        w, h = img.size
        orientation = orientation_of(img)  # applied to the decoded grey array
        factor = max(1, math.ceil(math.sqrt(w * h / WORK_PIXELS)))
        if factor > 1 and img.format == "JPEG":
            img.draft("L" if tone == "grey" else "RGB", (w // factor, h // factor))
        img.load()
        if factor > 1:
            step = max(1, round(img.size[0] / (w / factor)))
            if step > 1:
                img = _reduced(img, step)
        img = _flatten(img, tone)
        if factor > 1 and img.size[0] * img.size[1] > 1.05 * WORK_PIXELS:
            img = img.resize((w // factor, h // factor), Image.Resampling.BOX)
        grey = np.ascontiguousarray(upright(_grey_array(img), orientation))
    width, height = (w, h) if orientation < 5 else (h, w)  # the file's, as shown
    if factor > 1:
        notes.append(f"the picture ({width} × {height} px) was reduced to "
                     f"{grey.shape[1]} × {grey.shape[0]} px to trace it")
    scale = grey.shape[1] / width
    if orientation != 1:
        notes.append("the picture was turned upright as its EXIF orientation says")
    return grey, scale, notes


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().rstrip(".")
    return text[:80] if text else type(exc).__name__


def _reduced(img: object, step: int) -> object:
    """``img`` reduced ``step`` times (each ``step`` × ``step`` block's mean), a band of
    :data:`BAND_ROWS` rows at a time, so that nothing the decoded picture's size is held
    beside it (a 400-megapixel RGBA scan took 10 GB when it was flattened first). Values
    that are not tones are converted before they are averaged (:data:`AVERAGED_AS`:
    palette indices, bilevel pixels, 16-bit greys, which ``Image.reduce`` refuses), and
    alpha is premultiplied, so the colour hidden under transparent pixels never tints
    the ink beside them."""
    from PIL import Image

    assert isinstance(img, Image.Image)
    mode = AVERAGED_AS.get(img.mode, img.mode)
    if img.mode == "P" and "transparency" not in img.info:
        mode = "RGB"
    w, h = img.size
    rows = step * max(1, BAND_ROWS // step)
    out = Image.new(mode, (math.ceil(w / step), math.ceil(h / step)))
    for top in range(0, h, rows):
        band = img.crop((0, top, w, min(h, top + rows)))
        out.paste((band if band.mode == mode else band.convert(mode)).reduce(step),
                  (0, top // step))
    return out.convert(mode.upper()) if mode in ("La", "RGBa") else out  # straight alpha


def _flatten(img: object, tone: str = "grey") -> object:
    """The image in mode 'L', 'I;16'-like 'I' or 'F': palettes and colour converted to
    luminance (``tone`` "grey"), or to the darkest or lightest of each pixel's colour
    channels ("darkest", "lightest": :data:`TONES`), alpha composited over a paper of the
    opposite tone to what it shows: white under dark strokes (an app's export), black
    under light ones (a white logo on a transparent background, which over white would
    vanish), so the drawing is the visible part either way; polarity is then detected
    as for any picture."""
    from PIL import Image

    assert isinstance(img, Image.Image)
    mode = img.mode
    if mode == "P":
        img = img.convert("RGBA" if "transparency" in img.info else "RGB")
        mode = img.mode
    if mode in ("RGBA", "LA", "RGBa", "La", "PA"):
        img = img.convert("RGBA")
        alpha = np.asarray(img.getchannel("A"), np.float32)
        shade = np.asarray(img.convert("L"), np.float32)
        shown = float((alpha * shade).sum() / max(float(alpha.sum()), 1.0))  # 0–255
        under = 0 if shown > 127.5 else 255
        paper = Image.new("RGBA", img.size, (under, under, under, 255))
        img = _channels(Image.alpha_composite(paper, img), tone)
    elif mode in ("RGB", "CMYK", "YCbCr", "LAB", "HSV", "RGBX", "1"):
        img = _channels(img, tone)
    return img


def _channels(img: object, tone: str) -> object:
    """A colour image as one 'L' channel: its luminance, or each pixel's darkest or
    lightest colour channel (``tone``, :data:`TONES`)."""
    from PIL import Image

    assert isinstance(img, Image.Image)
    if tone == "grey" or img.mode == "1":
        return img.convert("L")
    rgb = np.asarray(img.convert("RGB"))
    return Image.fromarray(np.ascontiguousarray(
        rgb.min(axis=2) if tone == "darkest" else rgb.max(axis=2)), mode="L")


def _grey_array(img: object) -> np.ndarray:
    """Float32 (H, W) in [0, 1] of a flattened image (8-bit, 16-bit or float)."""
    a = np.asarray(img)
    if a.dtype == np.uint8 or a.dtype == bool:
        out = a.astype(np.float32) / (1.0 if a.dtype == bool else 255.0)
    elif a.dtype in (np.uint16, np.int32, np.uint32, np.int16):
        top = 65535.0 if a.max() > 255 else 255.0
        out = a.astype(np.float32) / top
    else:  # float: scaled by its largest finite value (one inf pixel blanked the rest)
        out = a.astype(np.float32)
        finite = out[np.isfinite(out)]
        hi = float(finite.max()) if finite.size else 1.0
        if hi > 1.0:
            out = out / hi
    if out.ndim != 2:
        raise InputError("the picture has an unexpected layout of channels; save it as a "
                         "grey or colour PNG.")
    return np.clip(np.nan_to_num(out, nan=1.0, posinf=1.0, neginf=0.0), 0.0, 1.0)


def read_picture(source: str, invert: bool = False) -> Picture:
    """The :class:`Picture` of the file ``source`` (module docstring); ``invert`` forces
    light ink on dark paper, otherwise it is detected. A colour picture whose luminance
    shows no ink is read again from its colour (:data:`TONES`), and that is said."""
    # there, no folder, not empty; its size is limited by its pixels, read from its header
    checked_input_file(source, "a picture of a line drawing", limit=PICTURE_FILE_BYTES)
    grey, scale, notes = decode(source)
    h, w = grey.shape
    if min(h, w) < 8:
        raise InputError(f"{source}: {w} × {h} px is too small to hold a drawing.")
    try:
        return _picture_of(source, grey, scale, notes, invert)
    except _Blank as blank:
        tone = "lightest" if blank.light or invert else "darkest"
        coloured, _, _ = decode(source, tone)
        if np.array_equal(coloured, grey):  # a grey picture: no colour to read
            raise
        notes.append(f"the ink was read from its colour (its {tone} channel): in grey it "
                     "is nearly as light as the paper")
        return _picture_of(source, coloured, scale, notes, invert)


class _Blank(InputError):
    """A page on which no ink was found; ``light``: it was read as light ink."""

    def __init__(self, light: bool, message: str) -> None:
        super().__init__(message)
        self.light = light


def _picture_of(source: str, grey: np.ndarray, scale: float, notes: list[str],
                invert: bool) -> Picture:
    """Steps 2–6 of the module docstring on a decoded ``grey`` picture."""
    notes = list(notes)
    page, inverted = _page_and_polarity(grey, invert)
    if invert and not _page_and_polarity(grey, False)[1]:
        notes.append("--invert reads it as light ink on dark paper, but it looks like dark "
                     "ink on light paper (then the ink traced is the paper between the "
                     "strokes); leave --invert out if its ink is dark")
    if inverted:
        grey = 1.0 - grey
        if not invert:
            notes.append("light ink on dark paper was detected and inverted")
    import cv2

    ink = ink_map(grey)
    if page is not None:
        ink[~page] = 0.0
        notes.append(f"the page was found in the picture, and what lies around it "
                     f"({100 * (1 - page.mean()):.0f} % of the picture) was left out")
    level = ink_threshold(ink)
    if level is not None and level < GRAINY * grain(ink, level):
        ink = cv2.GaussianBlur(ink, (0, 0), DENOISE)
        level = ink_threshold(ink)
        notes.append("the picture is grainy (a dim photo?): its grain was calmed before "
                     "the ink was told from the paper")
    mask, ruling, ruled = _drop_ruling_on(page, ink_mask(ink, level), ink, level)
    if ruled:
        notes.append(f"the paper's ruled lines ({', '.join(ruled)}) were left out")
    mask, sides = drop_edge_stripes(mask)
    if sides:
        notes.append(f"a stripe flush with the picture's {' and '.join(sides)} "
                     f"edge{'s' if len(sides) > 1 else ''} (a page's edge or a scanner's "
                     "shadow) was left out; crop the picture if it is part of the drawing")
    # each ink pixel's distance to the paper, read by the line-art check and the ink level
    depth = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    _check_line_art(source, ink, mask, depth, inverted and not invert, ruling, invert)
    return Picture(source, grey, ink, mask, scale, inverted, notes, ink_level(ink, depth),
                   page, ruling)


def _page_and_polarity(grey: np.ndarray, invert: bool) -> tuple[np.ndarray | None, bool]:
    """The page found in a photo of one on a desk (None where none is) and whether its ink
    is light (module docstring, steps 2 and 3): a light page with dark ink on it, or a
    dark page on a lighter desk (white ink on black paper: a light page in the inverted
    picture) with light ink on it; else the whole picture's polarity. ``invert`` forces
    light ink."""
    import cv2

    widest = widest_stroke(grey.shape)
    if invert:
        return find_page(1.0 - grey, widest), True
    calm = cv2.GaussianBlur(grey, (0, 0), DENOISE)  # calmed once for each polarity read
    light_page = find_page(grey, widest)
    if light_page is not None and not light_ink(calm, light_page):
        return light_page, False
    dark_page = find_page(1.0 - grey, widest)
    if dark_page is not None and light_ink(calm, dark_page):
        return dark_page, True
    return None, light_ink(calm)


def _drop_ruling_on(page: np.ndarray | None, mask: np.ndarray, ink: np.ndarray,
                    level: float | None) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """:func:`~inkmotion.tracing.ruling.drop_ruling` within the bounds of the ``page`` found
    in a photo (its ruled lines run from edge to edge of the page, not of the photo), or
    of the whole picture."""
    if page is None:
        return drop_ruling(mask, ink, level)
    rows, cols = np.flatnonzero(page.any(axis=1)), np.flatnonzero(page.any(axis=0))
    box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    inside, bands, ruled = drop_ruling(mask[box], ink[box], level)
    if bands is None:
        return mask, None, ruled
    out, ruling = mask.copy(), np.zeros_like(mask)
    out[box], ruling[box] = inside, bands
    return out, ruling, ruled


def widest_stroke(shape: tuple[int, int]) -> float:
    """The widest strokes (px) line art may have on a page of ``shape``:
    :data:`MAX_WIDTH_SHARE` of its longer side, at least :data:`LEAST_WIDEST`."""
    return max(MAX_WIDTH_SHARE * max(shape), LEAST_WIDEST)


def light_ink(calm: np.ndarray, page: np.ndarray | None = None) -> bool:
    """Whether the ink of a picture, on its ``page`` (H, W) bool where one was found, is
    lighter than its paper (module docstring, step 3): the side of the median its
    extremes reach further into, when that side reaches at least :data:`MIN_CONTRAST` and
    twice as far as the other; else whether the median is below ½. ``calm`` (H, W) is the
    picture's grey with its grain calmed (Gaussian, σ :data:`DENOISE`): a dim photo's
    noise reaches as far above its paper as below, and would hide which side its ink is
    on."""
    tones = calm if page is None else calm[page]
    low, paper, high = np.percentile(tones, [100 * TAIL, 50, 100 * (1 - TAIL)])
    dark, light = paper - low, high - paper
    if max(dark, light) >= MIN_CONTRAST and max(dark, light) >= 2 * min(dark, light):
        return bool(light > dark)
    return bool(paper < 0.5)


def paper_window(shape: tuple[int, int]) -> int:
    """Odd window (px) of the paper estimate: well over twice as wide as any stroke of
    line art (:func:`widest_stroke`), so the closing removes every stroke, yet far
    narrower than the page's changes of light."""
    return (int(2.4 * widest_stroke(shape)) + 3) | 1


def ink_map(grey: np.ndarray) -> np.ndarray:
    """Darkness of each pixel against its paper, [0, 1] (module docstring, step 4)."""
    import cv2

    k = paper_window(grey.shape)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
    calm = cv2.medianBlur(grey, 5)  # a max over grain would lift the paper (step 4)
    # the closing removes the dark strokes; its window is cut short at the border (the
    # border carried on outward would widen a stroke that runs along it into paper)
    paper = cv2.morphologyEx(calm, cv2.MORPH_CLOSE, kernel)
    return np.clip(1.0 - grey / np.maximum(paper, 1e-3), 0.0, 1.0).astype(np.float32)


def ink_threshold(ink: np.ndarray) -> float | None:
    """The darkness from which on a pixel is ink (module docstring, step 5): Otsu's
    threshold between faint paper and ink, never above half the darkest ink (all ink
    alike), never below :data:`MIN_CONTRAST`; None on a page with no ink to tell."""
    from skimage.filters import threshold_otsu

    dark = ink[ink > MIN_CONTRAST / 2]
    if dark.size <= 16:
        return None
    return max(MIN_CONTRAST, min(float(threshold_otsu(dark)),
                                 0.5 * float(np.percentile(dark, 99))))


def grain(ink: np.ndarray, level: float) -> float:
    """How grainy the paper of a darkness map ``ink`` is: the spread (σ, from the median
    absolute deviation) of its pixels lighter than half the ink's threshold ``level``."""
    paper = ink[ink < 0.5 * level]
    if paper.size < 16:
        return 0.0
    return float(1.4826 * np.median(np.abs(paper - np.median(paper))))


def ink_mask(ink: np.ndarray, level: float | None) -> np.ndarray:
    """The ink (H, W) bool of a darkness map above ``level`` (:func:`ink_threshold`),
    tidied (module docstring, step 5)."""
    from skimage.morphology import remove_small_holes, remove_small_objects

    if level is None:
        return np.zeros(ink.shape, bool)
    mask = _tidy((ink > level).astype(np.uint8))
    speck = max(4, int(round(1e-5 * mask.size)))
    # pieces joined at a corner are one (connectivity 2): a hairline drawn without
    # anti-aliasing (a paint program's pencil) runs diagonally pixel to pixel by corners
    mask = remove_small_objects(mask, max_size=speck, connectivity=2)
    return remove_small_holes(mask, max_size=speck)


def _longest_run(flags: np.ndarray) -> int:
    """The length of the longest run of True in the 1-D bool ``flags``."""
    edges = np.diff(np.concatenate(([0], flags.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return int((ends - starts).max()) if starts.size else 0


def drop_edge_stripes(mask: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """``mask`` without the stripes along its sides (module docstring, step 5), and the
    sides they were on ('top', 'bottom', 'left', 'right'). A stripe is a connected piece
    of ink whose outermost row (or column) is ink without a break over at least
    :data:`EDGE_RUN_SHARE` of that side, and all of which lies within a stroke's width
    (:func:`widest_stroke`) of it: a stroke that leaves the edge makes its piece too deep
    and keeps it."""
    h, w = mask.shape
    long = [side for side, line in _outer(mask).items()
            if _longest_run(line) >= EDGE_RUN_SHARE * line.size]
    if not long:  # the usual page: one cheap look at its four sides
        return mask, []
    from skimage.measure import label

    pieces = label(mask, connectivity=2)
    band = widest_stroke(mask.shape)
    depth_of = {"top": lambda r, c: r, "bottom": lambda r, c: h - 1 - r,  # from that side
                "left": lambda r, c: c, "right": lambda r, c: w - 1 - c}
    outer_pieces = _outer(pieces)
    out, sides = mask.copy(), []
    for side in long:
        line = outer_pieces[side]
        for piece in np.unique(line[line > 0]):
            if _longest_run(line == piece) < EDGE_RUN_SHARE * line.size:
                continue
            inside = pieces == piece
            if depth_of[side](*np.nonzero(inside)).max() < band:
                out[inside] = False
                sides.append(side)
    return out, sides


def _outer(a: np.ndarray) -> dict[str, np.ndarray]:
    """The outermost row or column of ``a`` (H, W) on each side, by the side's name."""
    return {"top": a[0], "bottom": a[-1], "left": a[:, 0], "right": a[:, -1]}


def ink_level(ink: np.ndarray, depth: np.ndarray) -> float:
    """The darkness of solid ink (module docstring, step 6): the median of ``ink`` over the
    ink pixels at least :data:`SOLID_DEPTH` px from the paper (``depth``, the mask's
    distance transform); 1 with fewer than :data:`SOLID_LEAST` of them."""
    solid = ink[depth >= SOLID_DEPTH]
    if solid.size < SOLID_LEAST:
        return 1.0
    return float(np.clip(np.median(solid), MIN_CONTRAST, 1.0))


def _tidy(raw: np.ndarray) -> np.ndarray:
    """A threshold's mask (H, W) uint8 0/1 with JPEG noise's burrs and notches evened out,
    as bool: a pixel with at most one ink neighbour of eight goes (a speck, a burr's tip)
    and a paper pixel with five or more is filled (a notch, as a 3 × 3 median fills it).
    Unlike a median this never breaks a line one pixel wide (each of its pixels has two
    ink neighbours), which a median erases wherever it runs near vertical or horizontal."""
    import cv2

    neighbours = cv2.filter2D(raw, cv2.CV_8U, np.ones((3, 3), np.float32),
                              borderType=cv2.BORDER_CONSTANT) - raw
    return np.where(raw > 0, neighbours >= 2, neighbours >= 5)


def _check_line_art(source: str, ink: np.ndarray, mask: np.ndarray, depth: np.ndarray,
                    found_light: bool = False, ruling: np.ndarray | None = None,
                    asked_light: bool = False) -> None:
    """Refuse a blank page, a page of mostly ink, and a picture that is not line art
    (``depth``: the mask's distance transform); ``found_light``: the page was read as
    light ink on its own (then a blank page says so, and what to do if the ink is
    dark); ``ruling``: the bands of the paper's ruled lines, no half-tones;
    ``asked_light``: ``--invert`` asked for light ink (then a refusal says to leave it
    out if the ink is dark, not to pass it)."""
    import cv2

    share = float(mask.mean())
    if share == 0.0 or mask.sum() < 16:
        if found_light:
            raise _Blank(found_light, f"{source}: no ink was found on this page, read as "
                         "light ink on dark paper (most of it is dark); if the ink is dark, "
                         "crop the picture to the paper it is on.")
        if asked_light:
            raise _Blank(found_light, f"{source}: no light ink was found on this page, read "
                         "as light ink on dark paper as --invert asks; check the file, or "
                         "leave --invert out for dark ink.")
        raise _Blank(found_light, f"{source}: no ink was found on this page (it looks blank); "
                     "check the file, or pass --invert for light ink on dark paper.")
    if share > MAX_INK_SHARE:
        raise InputError(f"{source}: {100 * share:.0f} % of the page is ink, which is not a line "
                         "drawing; crop it to the drawing, or " + (
                             "leave --invert out if the paper is the light part." if asked_light
                             else "pass --invert if the paper is the dark part."))
    calm = cv2.GaussianBlur(ink, (0, 0), DENOISE)  # grain is no half-tone
    band = widest_stroke(mask.shape)
    tones = (calm > MIN_CONTRAST) & ~mask  # between paper and ink, ruled lines aside
    if ruling is not None:
        tones &= ~ruling
    mid = float(tones.mean())
    if mid > max(0.05, 2.0 * share):
        found = f"{100 * mid:.0f} % of the page is in half-tones"
        raise InputError(_beside_the_page(source, found, tones, band) or (
            f"{source}: {found}, not a line drawing (a photo is drawn by `inkmotion run "
            "abstract`); use a picture of line art on plain paper."))
    widest = 2.0 * float(np.percentile(depth[mask], 95))
    if widest > band and (found_light or widest > BRUSH_SHARE * max(mask.shape)
                          or not _brush_ink(mask, depth)):
        read = ("light areas (read as light ink on dark paper, as most of it is dark: if "
                "the ink is dark, crop the picture to the paper it is on)" if found_light
                else "light areas (read as ink, as --invert asks: if the ink is dark, leave "
                "--invert out)" if asked_light else "dark areas")
        found = f"the {read} are {widest:.0f} px wide, too wide for line art"
        raise InputError((not found_light and _beside_the_page(
            source, found, depth > band / 2, band)) or (
            f"{source}: {found} on a page this size, so this is not a line drawing; use a "
            "picture of line art (a photo is drawn by `inkmotion run abstract`)."))


def _brush_ink(mask: np.ndarray, depth: np.ndarray) -> bool:
    """Whether the ink of ``mask`` (H, W) bool runs on as a broad brush's strokes do: its
    pieces' area over the sum of their squared widths (each piece's width twice its
    deepest ``depth``, the distance transform) is at least :data:`BRUSH_LENGTH`, the
    length of its strokes in widths; a blot or a blotch is about as wide as it is long."""
    import cv2
    from scipy import ndimage

    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8),
                                                               connectivity=8)
    if count < 2:
        return False
    widths = 2.0 * np.asarray(ndimage.maximum(depth, labels, np.arange(1, count)))
    area = float(stats[1:, cv2.CC_STAT_AREA].sum())
    return area >= BRUSH_LENGTH * float((np.maximum(widths, 1.0) ** 2).sum())


def _beside_the_page(source: str, found: str, where: np.ndarray, band: float) -> str:
    """The refusal of ``source`` for what was ``found`` where ``where`` (H, W) bool
    says, when that lies along one or two sides of the picture (within ``band`` px of
    each, over half its length; most of it there): it may be a desk or a shadow beside
    the page, to be cropped away; else ""."""
    import cv2

    reach = max(1, int(round(band)))
    along = {"top": where[:reach].any(axis=0), "bottom": where[-reach:].any(axis=0),
             "left": where[:, :reach].any(axis=1), "right": where[:, -reach:].any(axis=1)}
    sides = [side for side, seen in along.items() if seen.mean() > 0.5]
    if not sides or len(sides) > 2:
        return ""  # none, or all round: a photo, not a page beside a desk
    _, pieces = cv2.connectedComponents(where.astype(np.uint8), connectivity=8)
    edge = np.zeros_like(where)
    edge[:reach], edge[-reach:], edge[:, :reach], edge[:, -reach:] = True, True, True, True
    touching = np.unique(pieces[edge & where])
    if np.isin(pieces, touching[touching > 0]).sum() < 0.6 * where.sum():
        return ""  # most of it stands away from the sides: not beside the page
    return (f"{source}: {found}, mostly along the picture's {' and '.join(sides)} edge; if "
            "that is a desk or a shadow beside the page, crop the picture to the page.")
