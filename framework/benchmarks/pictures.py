"""Fits from pictures against the true trace: recorded drawings rendered as a scan would
see them, fitted from the picture alone, and scored against the recording.

``python -m inkmotion.benchmarks.pictures OUT SOURCE...`` (``--steps N``,
``--fit-option=OPT``, ``--jobs N`` fits at once) renders each source at every
:data:`SCANS` setting (``--scan NAME`` for some, or for the pencil sketches on plain,
ruled and squared paper and the photo of a page on a desk of :data:`PAPERS`), runs
``inkmotion run fit`` on the picture (a separate process, as a user would;
``--fit-option`` adds an option of its own to every fit) and prints a table;
``OUT/pictures.json`` holds every figure.

Scores (fitted motion against the true trace, both on the fit's canvas):

- Chamfer mean / max (px) (:mod:`inkmotion.geometry.chamfer`);
- direction: the share of the true ink length (1-px samples) that the motion passes in
  the recorded direction: a fitted sample within 1 px of the nearest one and running
  along the stroke (|cos| > 0.7), or the nearest one, whose tangent has a positive dot
  product with the stroke's (a place the motion passes twice, out to a cusp's point and
  back, counts the pass that agrees);
- order: the share of pairs of true strokes that the motion reaches in their recorded
  order (each stroke's median arrival time; 'n/a' for one stroke);
- plan size m, T_end ratio, Δt at a bound, extraction seconds (in the fit process, so the
  first extraction of a process, its libraries' first imports and calls included), wall
  seconds;
- with ``--varying-width``, the IoU of the rendered motion and the picture's ink.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from inkmotion.json_files import dumps


@dataclass(frozen=True)
class Scan:
    """How a recorded drawing is rendered as a picture."""

    name: str
    size: int = 1000  # longer side, px
    brush: float = 8.0  # ink width, px
    blur: float = 0.0  # Gaussian sigma, px
    noise: float = 0.0  # grey noise sigma (0..1 scale)
    jpeg: int = 0  # JPEG quality, 0 for PNG
    paper: float = 1.0  # paper grey
    gradient: float = 0.0  # light falling off across the page (share of the paper grey)
    varying: bool = False  # fit with --varying-width
    ink: float = 0.85  # how dark the ink is (a pencil's is lighter)
    ruling: float = 0.0  # ruled paper: its lines' spacing, a share of the size (0: plain)
    squared: bool = False  # ruled both ways (graph paper)
    tilt: float = 0.0  # degrees the ruling leans (a page photographed a little askew)
    desk: float = 0.0  # a photo of the page on a desk: the share of the photo round it
    turn: float = 0.0  # ... and the degrees the page is turned on the desk


SCANS = (
    Scan("clean-350-w2", size=350, brush=2.0),
    Scan("scan-1000-w8", size=1000, brush=8.0, blur=1.0, noise=0.03, jpeg=70, paper=0.9,
         gradient=0.25),
    Scan("brush-1000-w16", size=1000, brush=16.0, blur=1.5, noise=0.03, jpeg=70, paper=0.85,
         gradient=0.3),
    Scan("photo-700-w5", size=700, brush=5.0, blur=1.0, noise=0.05, jpeg=70, paper=0.8,
         gradient=0.4),
)
#: pencil sketches on plain, ruled and squared paper, and a photo of a page on a desk
#: (``--scan`` names them; not in the default set): the ruling's lines 2 px wide every
#: 3.5 % of the size, leaning 1°, printed a third as dark as the paper
#: (:mod:`inkmotion.tracing.ruling`)
PAPERS = (
    Scan("pencil-1000-w8", size=1000, brush=8.0, blur=1.0, noise=0.03, jpeg=70, paper=0.92,
         ink=0.55),
    Scan("lined-1000-w8", size=1000, brush=8.0, blur=1.0, noise=0.03, jpeg=70, paper=0.92,
         ink=0.55, ruling=0.035, tilt=1.0),
    Scan("squared-1000-w8", size=1000, brush=8.0, blur=1.0, noise=0.03, jpeg=70, paper=0.92,
         ink=0.55, ruling=0.035, squared=True, tilt=1.0),
    # a phone photo of the page on a grained dark desk (:mod:`inkmotion.tracing.page`)
    Scan("desk-1000-w8", size=1000, brush=8.0, blur=1.0, noise=0.03, jpeg=70, paper=0.9,
         gradient=0.25, desk=0.4, turn=3.0),
)


def render_scan(strokes: list[np.ndarray], scan: Scan, path: Path, seed: int = 0
                ) -> np.ndarray:
    """Draw ``strokes`` (picture px, pixel centres at half-integers) as ``scan`` says;
    returns the affine map (2, 3) from the strokes' px to the picture's (the identity but
    for a page photographed on a desk)."""
    import cv2

    xs = np.concatenate([s[:, 0] for s in strokes])
    ys = np.concatenate([s[:, 1] for s in strokes])
    w, h = int(np.ceil(xs.max() + scan.size * 0.08)), int(np.ceil(ys.max() + scan.size * 0.08))
    ink = np.zeros((h, w), np.uint8)
    t = max(1, int(round(scan.brush)))
    for s in strokes:
        pts = np.round((s[:, :2] - 0.5) * 16).astype(np.int32)
        cv2.polylines(ink, [pts], False, 255, t, cv2.LINE_AA, 4)
    cover = ink.astype(np.float32) / 255.0
    if scan.blur > 0:
        cover = cv2.GaussianBlur(cover, (0, 0), scan.blur)
    light = scan.paper * (1.0 - scan.gradient * np.linspace(0, 1, w)[None, :]
                          * np.linspace(0.3, 1, h)[:, None])
    grey = light * (1.0 - scan.ink * cover)
    if scan.ruling:
        gap = max(4, int(round(scan.ruling * scan.size)))
        grey = grey * (1.0 - 0.3 * ruled_lines(h, w, gap, scan.tilt, scan.squared))
    rng = np.random.default_rng(seed)
    place = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    if scan.desk:
        grey, place = on_a_desk(grey, scan.desk, scan.turn, rng)
    grey = grey + rng.normal(0.0, scan.noise, grey.shape) if scan.noise > 0 else grey
    img = np.clip(grey * 255, 0, 255).astype(np.uint8)
    if scan.jpeg:
        cv2.imwrite(str(path), img, [cv2.IMWRITE_JPEG_QUALITY, scan.jpeg])
    else:
        cv2.imwrite(str(path), img)
    return place


def on_a_desk(page: np.ndarray, share: float, turn: float, rng: np.random.Generator,
              tone: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """A photo (grey, [0, 1]) of ``page`` lying on a desk ``tone`` as light, with a wood
    grain, turned ``turn`` degrees, the desk taking ``share`` of the photo round it; and
    the affine map (2, 3) from the page's px to the photo's."""
    import cv2

    h, w = page.shape
    grow = 1.0 / math.sqrt(1.0 - share)
    big_h, big_w = int(round(h * grow)), int(round(w * grow))
    place = cv2.getRotationMatrix2D((w / 2, h / 2), turn, 1.0)
    place[:, 2] += ((big_w - w) / 2, (big_h - h) / 2)
    photo = cv2.warpAffine(page.astype(np.float32), place, (big_w, big_h),
                           flags=cv2.INTER_LINEAR, borderValue=-1.0)
    grain = tone * (1 + 0.15 * np.sin(np.linspace(0, 9 * big_w / 100, big_w))[None, :]
                    * (1 + 0.5 * np.sin(np.linspace(0, 5, big_h)))[:, None])
    grain = grain + rng.normal(0.0, 0.02, grain.shape)
    photo = np.where(photo < 0, grain, photo)
    centres = place.copy()  # pixel centres at half-integers, as the strokes have them
    centres[:, 2] += 0.5 - place[:, :2] @ np.array([0.5, 0.5])
    return cv2.GaussianBlur(photo.astype(np.float32), (0, 0), 0.8), centres


def ruled_lines(h: int, w: int, gap: int, tilt: float = 0.0, squared: bool = False,
                width: int = 2) -> np.ndarray:
    """A page's ruled lines (H, W) in [0, 1]: ``width`` px wide, ``gap`` px apart across
    it (and down it too, ``squared``), leaning ``tilt`` degrees."""
    import cv2

    lines = np.zeros((h, w), np.uint8)
    lean = float(np.tan(np.radians(tilt)))
    for y in range(-h, 2 * h, gap):
        cv2.line(lines, (0, y), (w - 1, int(y + lean * w)), 255, width, cv2.LINE_AA)
    if squared:
        for x in range(-w, 2 * w, gap):
            cv2.line(lines, (x, 0), (int(x - lean * h), h - 1), 255, width, cv2.LINE_AA)
    return lines.astype(np.float32) / 255.0


def _samples(csv: Path) -> list[np.ndarray]:
    """The fitted motion's samples per path (k, 3): x, y and a global time order."""
    data = np.genfromtxt(csv, delimiter=",", names=True)
    paths = []
    for i, p in enumerate(np.unique(data["path"])):
        sel = data["path"] == p
        order = i * 1e6 + data["t"][sel]
        paths.append(np.column_stack((data["x"][sel], data["y"][sel], order)))
    return paths


def direction_and_order(truth: list[np.ndarray], motion: list[np.ndarray]
                        ) -> tuple[float, float | None]:
    """Module docstring: the direction share and the order share (None for one stroke)."""
    from scipy.spatial import cKDTree

    from inkmotion.geometry.chamfer import densify

    pts = np.vstack(motion)
    tangent = np.vstack([np.gradient(m[:, :2], axis=0) if len(m) > 1 else np.zeros((1, 2))
                         for m in motion])
    tree = cKDTree(pts[:, :2])
    same = total = 0.0
    arrival = []
    for s in truth:
        d = densify(s[:, :2], 1.0)
        if len(d) < 2:
            continue
        tang = np.gradient(d, axis=0)
        dist, near = tree.query(d, k=min(12, len(pts)))
        dist, near = dist.reshape(len(d), -1), near.reshape(len(d), -1)
        cos = np.einsum("ij,ikj->ik", tang, tangent[near]) / np.maximum(
            np.hypot(*tang.T)[:, None] * np.linalg.norm(tangent[near], axis=2), 1e-12)
        # a pass through here: within 1 px of the nearest sample and along the stroke
        passes = (dist <= dist[:, :1] + 1.0) & (np.abs(cos) > 0.7)
        passes[:, 0] = True  # the nearest sample always counts
        cos = np.where(passes, cos, -2.0)
        agree = cos.max(axis=1) > 0
        idx = near[np.arange(len(d)), np.argmax(cos, axis=1)]
        seg = np.hypot(*tang.T)
        same += float(seg[agree].sum())
        total += float(seg.sum())
        arrival.append(float(np.median(pts[idx, 2])))
    pairs = [(i, j) for i in range(len(arrival)) for j in range(i + 1, len(arrival))]
    order = (sum(arrival[i] < arrival[j] for i, j in pairs) / len(pairs)) if pairs else None
    return (same / total if total else float("nan")), order


def run_one(source: str, scan: Scan, out: Path, steps: int | None,
            options: tuple[str, ...] = ()) -> dict:
    """Render, fit and score one source at one setting (``options``: more options of
    ``inkmotion run fit``, e.g. ``("--lambda", "80")``)."""
    import cv2

    from inkmotion.geometry.chamfer import chamfer
    from inkmotion.kinds.read import read_input

    name = (source.replace(":", "-") if source.startswith("text:")
            else Path(source.split(":", 1)[-1]).stem)
    folder = out / f"{name}--{scan.name}"
    folder.mkdir(parents=True, exist_ok=True)
    truth = read_input(source).fit_to_canvas(scan.size).strokes  # picture px
    pic = folder / ("picture.jpg" if scan.jpeg else "picture.png")
    place = render_scan(truth, scan, pic)
    truth = [s[:, :2] @ place[:, :2].T + place[:, 2] for s in truth]  # picture px
    cmd = [str(Path(sys.executable).parent / "inkmotion"), "run", "fit", str(pic), "--out",
           str(folder / "fit"), "--force", "--no-record"]
    if steps:
        cmd += ["--steps", str(steps)]
    if scan.varying:
        cmd.append("--varying-width")
    cmd += options
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    row: dict = {"source": source, "scan": scan.name, "wall_s": round(wall, 2)}
    if done.returncode != 0:
        row["error"] = (done.stderr.strip().splitlines() or ["?"])[-1]
        return row
    report = json.loads((folder / "fit" / "report.json").read_text())
    ex = report["extraction"]
    m = ex["canvas_from_picture"]
    on_canvas = [s[:, :2] * ex["decoded_scale"] * m["scale"] + np.asarray(m["offset"])
                 for s in truth]
    motion = _samples(folder / "fit" / "trajectory.csv")
    mean, worst = chamfer(on_canvas, [p[:, :2] for p in motion])
    direction, order = direction_and_order(on_canvas, motion)
    row.update(true_strokes=len(truth), strokes=ex["strokes"], moves=report["moves"],
               chamfer_mean_px=round(mean, 3), chamfer_max_px=round(worst, 2),
               direction=round(direction, 3),
               order=None if order is None else round(order, 3),
               t_end_ratio_multi=round(report["t_end_ratio_multi"], 3),
               delta_t_at_clamp=report["delta_t_at_clamp"],
               extraction_s=ex["seconds"], fit_s=report["fit_s"], job_s=report["wall_s"])
    if scan.varying:
        drawn = cv2.imread(str(folder / "fit" / "drawing.png"), cv2.IMREAD_GRAYSCALE)
        from inkmotion.tracing import read_picture, trace_picture

        size = json.loads((folder / "fit" / "job.json").read_text())["spec"]["params"]["size"]
        ink = trace_picture(read_picture(str(pic)), True).fit_to_canvas(size).picture
        a, b = (255 - drawn) > 127, ink > 0.5
        if a.shape == b.shape:
            row["iou"] = round(float((a & b).sum() / max((a | b).sum(), 1)), 3)
    return row


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("sources", nargs="+")
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--scan", action="append",
                        help="only these settings (names; also the pencil and ruled-paper "
                             "ones, which the default set leaves out)")
    parser.add_argument("--varying", action="store_true", help="fit --varying-width too")
    parser.add_argument("--fit-option", action="append", default=[], metavar="OPTION",
                        help="an option of inkmotion run fit for every fit, repeatable, "
                             "e.g. --fit-option=--lambda=80")
    parser.add_argument("--jobs", type=int, default=1,
                        help="fits run at once, each a process of its own (default 1)")
    args = parser.parse_args(argv)
    scans = [s for s in SCANS if not args.scan or s.name in args.scan]
    scans += [s for s in PAPERS if args.scan and s.name in args.scan]
    if args.varying:
        scans = [Scan(**{**asdict(s), "name": s.name + "-vw", "varying": True}) for s in scans]
    if args.jobs < 1:
        parser.error(f"--jobs takes 1 or more fits at once, not {args.jobs}")
    work = [(source, scan) for source in args.sources for scan in scans]
    rows: list[dict] = []
    # each fit is a process of its own with its own fixed thread count: N of them side by
    # side give the plans they give alone; the rows come in the order of the work
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for row in pool.map(lambda w: run_one(w[0], w[1], args.out, args.steps,
                                              tuple(args.fit_option)), work):
            rows.append(row)
            print(dumps(row), flush=True)
            (args.out / "pictures.json").write_text(dumps(rows, indent=1))


if __name__ == "__main__":
    main()
