"""End-to-end: the 'tag' and 'abstract' job kinds through the real command line, on a tiny
randomly initialised CLIP model (tests/data/clip/tiny-vit.json): nothing is downloaded."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch

DATA = Path(__file__).parent / "data"
TINY = str(DATA / "clip" / "tiny-vit.json")
COMMON = {"plan.json", "drawing.svg", "drawing.png", "overlay.png", "speed.png",
          "trajectory.csv", "init.json", "init.png", "job.json", "report.json"}


def inkmotion(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    full = {**os.environ, "PYTHONWARNINGS": "default", **(env or {})}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, env=full)


def write_photo(path: Path, size: int = 96) -> Path:
    """A small colour photo: a bright disc and a bar on a dark gradient."""
    import cv2

    yy, xx = np.mgrid[0:size, 0:size]
    img = np.stack([40 + 60 * xx / size, 50 + 0 * xx, 70 + 50 * yy / size], -1)
    img[(xx - size * 0.35) ** 2 + (yy - size * 0.4) ** 2 < (size * 0.18) ** 2] = (240, 220, 80)
    img[int(size * 0.7):int(size * 0.8), int(size * 0.2):int(size * 0.85)] = (200, 200, 230)
    cv2.imwrite(str(path), img.astype(np.uint8))
    return path


@pytest.fixture(scope="module")
def tag_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("tag") / "cream"
    res = inkmotion("run", "tag", "CREAM", "--clip-model", TINY, "--clip-weights", "random",
                    "--steps", "12", "--size", "64", "--targets", "8", "--out", str(out))
    assert res.returncode == 0, res.stderr
    (out.parent / "stderr.txt").write_text(res.stderr)
    return out


@pytest.fixture(scope="module")
def abstract_dir(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("abstract")
    photo = write_photo(base / "photo.png")
    out = base / "photo"
    res = inkmotion("run", "abstract", str(photo), "--clip-model", TINY, "--clip-weights",
                    "random", "--steps", "8", "--size", "80", "--targets", "40",
                    "--varying-width", "--spray-preview", "--out", str(out))
    assert res.returncode == 0, res.stderr
    return out


def test_tag_writes_every_artifact_and_records_random_weights(tag_dir: Path) -> None:
    assert COMMON <= {p.name for p in tag_dir.iterdir()}
    report = json.loads((tag_dir / "report.json").read_text())
    job = json.loads((tag_dir / "job.json").read_text())
    assert report["clip_weights"] == "random" and job["clip_weights"] == "random"
    assert job["spec"]["params"]["clip_weights"] == "random"
    assert report["caption"] == "CREAM, a stylish graffiti tag"
    assert report["steps"] == 12 and report["paths"] == 1 and report["moves"] == 8
    init = json.loads((tag_dir / "init.json").read_text())
    plan = json.loads((tag_dir / "plan.json").read_text())
    assert init["paths"][0]["delta_t"] == [1.0] * 8  # the paper's plain start, Δt = 1
    assert plan["paths"][0]["points"] != init["paths"][0]["points"]


def test_abstract_is_one_varying_width_path(abstract_dir: Path) -> None:
    assert COMMON | {"saliency.png", "spray.png"} <= {p.name for p in abstract_dir.iterdir()}
    plan = json.loads((abstract_dir / "plan.json").read_text())
    assert len(plan["paths"]) == 1
    points = np.array(plan["paths"][0]["points"])
    assert points.shape == (40, 3)  # 40 targets of the tour, (x, y, r)
    report = json.loads((abstract_dir / "report.json").read_text())
    assert report["varying_width"] and report["clip_weights"] == "random"
    assert report["canvas"] == {"width": 80, "height": 80}
    header = (abstract_dir / "trajectory.csv").read_text().splitlines()[0]
    assert header.split(",")[:5] == ["path", "t", "x", "y", "r"]


def test_the_random_weights_warning_is_said_once(tag_dir: Path) -> None:
    from inkmotion.clip.model import RANDOM_WARNING

    stderr = (tag_dir.parent / "stderr.txt").read_text()
    assert stderr.count("random") == 1, stderr  # not open_clip's, warnings' and the log's
    assert f"warning: {RANDOM_WARNING}" in stderr
    assert "No pretrained weights" not in stderr and "UserWarning" not in stderr
    report = json.loads((tag_dir / "report.json").read_text())
    assert report["warnings"] == [RANDOM_WARNING]  # and the store's record says it too


def test_a_photo_that_is_no_image_fails_before_clip_is_loaded(tmp_path: Path) -> None:
    """The cheap check (is the file an image?) runs before the costly one (CLIP): the job
    fails with one sentence and open_clip is never imported."""
    bad = tmp_path / "photo.png"
    bad.write_text("a text file, not a photo")
    probe = ("import sys\n"
             "from inkmotion.cli.main import main\n"
             f"sys.argv = ['inkmotion', 'run', 'abstract', {str(bad)!r}, '--clip-model', "
             f"{TINY!r}, '--clip-weights', 'random', '--out', {str(tmp_path / 'out')!r}]\n"
             "try:\n    main()\n"
             "except SystemExit as exc:\n"
             "    print('exit', exc.code, 'open_clip' in sys.modules)\n")
    res = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         timeout=300)
    assert res.stdout.split() == ["exit", "1", "False"], (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(bad) in lines[0]
    assert not (tmp_path / "out").exists()


def test_missing_weights_stop_before_any_work(tmp_path: Path) -> None:
    empty = tmp_path / "cache"
    empty.mkdir()
    env = {"HF_HOME": str(empty), "HF_HUB_CACHE": str(empty / "hub"),
           "XDG_CACHE_HOME": str(empty), "HF_HUB_OFFLINE": "1"}
    out = tmp_path / "never"
    res = inkmotion("run", "tag", "CREAM", "--out", str(out), env=env)
    assert res.returncode != 0
    message = res.stderr.strip()
    assert "inkmotion clip download" in message and "--clip-weights" in message
    assert "Traceback" not in res.stderr
    assert not out.exists() and not list(tmp_path.glob("never*"))


@pytest.mark.parametrize("content,why", [(b"", "empty"), (b"not an image", "not an image")])
def test_unreadable_image_is_refused_naming_the_file(tmp_path: Path, content: bytes,
                                                    why: str) -> None:
    bad = tmp_path / "broken.png"
    bad.write_bytes(content)
    res = inkmotion("run", "abstract", str(bad), "--clip-model", TINY, "--clip-weights",
                    "random", "--out", str(tmp_path / "out"))
    assert res.returncode != 0
    assert str(bad) in res.stderr and why in res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "out").exists()


def test_images_grey_colour_alpha_and_16_bit(tmp_path: Path) -> None:
    import cv2

    from inkmotion.images.load import load_image

    grey = np.tile(np.linspace(0, 255, 50, dtype=np.uint8), (30, 1))
    cv2.imwrite(str(tmp_path / "grey.png"), grey)
    rgba = np.zeros((30, 50, 4), np.uint8)
    rgba[..., 2] = 255  # red in BGRA
    rgba[:, :25, 3] = 255  # left half opaque, right half transparent
    cv2.imwrite(str(tmp_path / "alpha.png"), rgba)
    cv2.imwrite(str(tmp_path / "deep.png"), (grey.astype(np.uint16) * 257))
    cv2.imwrite(str(tmp_path / "photo.jpg"), np.dstack([grey] * 3))
    g = load_image(tmp_path / "grey.png", 100)
    assert g.shape == (3, 60, 100) and torch.equal(g[0], g[1])
    a = load_image(tmp_path / "alpha.png", 50)
    assert torch.allclose(a[:, 5, 5], torch.tensor([1.0, 0.0, 0.0]))  # opaque red
    assert torch.allclose(a[:, 5, 45], torch.ones(3))  # transparent → white paper
    d = load_image(tmp_path / "deep.png", 50)
    assert torch.allclose(d, g_small := load_image(tmp_path / "grey.png", 50), atol=1e-3), \
        g_small.shape
    assert load_image(tmp_path / "photo.jpg", 25).shape == (3, 15, 25)


def test_blank_image_is_refused(tmp_path: Path) -> None:
    import cv2

    from inkmotion.errors import InputError
    from inkmotion.images.load import load_image

    cv2.imwrite(str(tmp_path / "white.png"), np.full((20, 20), 255, np.uint8))
    with pytest.raises(InputError, match="white.png: the image is blank"):
        load_image(tmp_path / "white.png", 64)


def test_tag_and_abstract_listed_with_their_options() -> None:
    wide = {"COLUMNS": "250", "TERMINAL_WIDTH": "250"}
    res = inkmotion("run", "abstract", "--help", env=wide)
    assert res.returncode == 0
    for flag in ("--targets", "--varying-width", "--saliency", "--clip-weights", "--loss"):
        assert flag in res.stdout
    res = inkmotion("run", "tag", "--help", env=wide)
    assert "--caption" in res.stdout and "stylish graffiti tag" in res.stdout


def test_a_loss_level_clip_choice_is_refused_in_favour_of_the_jobs() -> None:
    from inkmotion.errors import SpecError
    from inkmotion.jobs.kind import resolve
    from inkmotion.jobs.spec import JobSpec

    spec = JobSpec(kind="tag", inputs={"word": "X"},
                   params={"losses": [{"name": "clip-text", "weights": "random"}]})
    with pytest.raises(SpecError, match="give --clip-weights random instead"):
        resolve(spec)
    full = resolve(JobSpec(kind="tag", inputs={"word": "X"})).full_spec()
    resolve(full)  # the defaults written into job.json are accepted back


def test_clip_status_says_what_is_missing_and_what_is_ready(tmp_path: Path) -> None:
    env = {"HF_HOME": str(tmp_path), "HF_HUB_CACHE": str(tmp_path / "hub"),
           "XDG_CACHE_HOME": str(tmp_path)}
    missing = inkmotion("clip", "status", env=env)
    assert missing.returncode == 1 and "inkmotion clip download" in missing.stdout
    ready = inkmotion("clip", "status", "--model", TINY, "--weights", "random", env=env)
    assert ready.returncode == 0 and "ready" in ready.stdout
    assert "random weights: results are meaningless" in ready.stdout
    # a checkpoint of another model said "ready", and the job then refused it
    import torch

    from inkmotion.clip.model import load_clip

    other = tmp_path / "tiny.pt"
    with warnings.catch_warnings():  # said once per model built: this process may have
        warnings.filterwarnings("ignore", "CLIP weights are random")  # built it already
        torch.save(load_clip(TINY, weights="random").model.state_dict(), other)
    wrong = inkmotion("clip", "status", "--weights", str(other), env=env)
    assert wrong.returncode == 1 and "does not load into the model ViT-B-32" in wrong.stderr
    right = inkmotion("clip", "status", "--model", TINY, "--weights", str(other), env=env)
    assert right.returncode == 0 and "ready" in right.stdout, right.stderr


def test_a_caption_longer_than_clip_reads_is_said(tmp_path: Path) -> None:
    """A 5000-letter word and a 1000-letter one gave byte-identical tags: CLIP reads 77
    tokens and the rest (", a stylish graffiti tag" too) was cut off without a word."""
    from inkmotion.jobs.shell import run_job
    from inkmotion.jobs.spec import JobSpec

    spec = JobSpec(kind="tag", inputs={"word": "WILDSTYLE " * 40}, params={
        "clip_model": TINY, "clip_weights": "random", "steps": 2, "targets": 6, "size": 64})
    report = run_job(spec, tmp_path / "long")
    (said,) = [w for w in report["warnings"] if "CLIP tokens" in w]
    assert "the caption is 87 CLIP tokens and CLIP reads 77: its last 10 are cut off" in said
    short = run_job(JobSpec(kind="tag", inputs={"word": "WILD"}, params=spec.params),
                    tmp_path / "short")
    assert not [w for w in short["warnings"] if "CLIP tokens" in w]
