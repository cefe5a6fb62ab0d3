"""``inkmotion gallery build``: what the site shows of real jobs, its incremental rebuilds,
its links, and the errors a user meets (the browser checks are in test_gallery_browser)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import time
import urllib.request
from html.parser import HTMLParser
from pathlib import Path

import cv2
import pytest
from service_fixtures import inkmotion_cli

from inkmotion import store
from inkmotion.errors import ServiceError, SpecError
from inkmotion.gallery import build_gallery, collect


class Page(HTMLParser):
    """The elements of an HTML page: (tag, attributes, text until the next tag)."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.elements: list[tuple[str, dict[str, str], list[str]]] = []
        self.feed(path.read_text(encoding="utf-8"))

    def handle_starttag(self, tag: str, attrs: list) -> None:
        self.elements.append((tag, {k: v or "" for k, v in attrs}, []))

    def handle_data(self, data: str) -> None:
        if self.elements:
            self.elements[-1][2].append(data)

    def find(self, tag: str, **attrs: str) -> list[dict[str, str]]:
        return [a for t, a, _ in self.elements
                if t == tag and all(a.get(k.replace("_", "-")) == v for k, v in attrs.items())]

    def text(self, tag: str, **attrs: str) -> str:
        for t, a, text in self.elements:
            if t == tag and all(a.get(k) == v for k, v in attrs.items()):
                return "".join(text).strip()
        raise AssertionError(f"no <{tag} {attrs}>")

    @property
    def all_text(self) -> str:
        return " ".join("".join(t) for _, _, t in self.elements)


def build(jobs, out: Path, **kwargs):
    entries = collect(store=True, folders=[jobs.results], db_url=jobs.db_url)
    return build_gallery(entries, out, **kwargs)


def cards(out: Path) -> dict[str, dict[str, str]]:
    return {c["data-id"]: c for c in Page(out / "index.html").find("li", **{"class": "card"})}


def test_index_has_a_card_per_job_with_its_figures(gallery_jobs, tmp_path):
    report = build(gallery_jobs, tmp_path / "site")
    shown = cards(tmp_path / "site")
    assert report.jobs == len(shown) == 8  # 5 store rows + 3 results folders
    ids = gallery_jobs.ids
    assert {shown[ids[s]]["data-status"] for s in ids} == {
        "succeeded", "running", "failed", "queued"}
    kinds = sorted(c["data-kind"] for c in shown.values())
    assert kinds == ["evaluate"] + ["fit"] * 6 + ["simulate"]
    page = Page(tmp_path / "site" / "index.html")
    text = page.all_text
    for label in ("text:hi", "text:running word", "text:broken", "text:waiting"):
        assert label in text
    metrics = json.loads((gallery_jobs.fit / "report.json").read_text())["metrics"]
    assert f"{metrics['chamfer_mean_px']:.3g}" in text and f"{metrics['t_end_ratio']:.3g}×" in text
    assert "no glyphs to draw" in text  # the failed job's error on its card
    assert "is missing" in text  # the job whose artifacts were deleted says so
    assert any(ids["missing"] in p for p in report.problems)
    # the running job's progress bar, 3 of 8 steps
    assert 'title="step 3 of 8"' in (tmp_path / "site" / "index.html").read_text()
    # key parameters on the card: the plugins and what differs from the defaults
    card_text = (tmp_path / "site" / "index.html").read_text()
    assert "<code>steps</code> 8" in card_text and "<code>initialiser</code> dce" in card_text
    # thumbnails: real PNGs no wider than 360 px, only for jobs with images
    for job_id, card in shown.items():
        thumb = tmp_path / "site" / "jobs" / job_id / "thumb.png"
        has_images = card["data-status"] == "succeeded" and job_id != ids["missing"]
        assert thumb.is_file() == has_images, job_id
        if has_images:
            image = cv2.imread(str(thumb))
            assert image is not None and image.shape[1] <= 360 and image.std() > 1


def test_detail_page_shows_figures_evaluation_downloads_and_commands(gallery_jobs, tmp_path):
    build(gallery_jobs, tmp_path / "site")
    site = tmp_path / "site"
    by_kind = {c["data-kind"]: c["data-id"] for c in cards(site).values()
               if c["data-status"] == "succeeded" and c["data-id"].startswith("run-")}
    by_kind["fit-store"] = gallery_jobs.ids["succeeded"]
    fit = Page(site / "jobs" / by_kind["fit"] / "index.html")
    images = {a["src"] for a in fit.find("img")}
    assert {"files/drawing.svg", "files/overlay.png", "files/speed.png",
            "files/spray.png"} <= images
    downloads = {a["href"] for a in fit.find("a", download="")}
    assert {"files/drawing.svg", "files/plan.json", "files/trajectory.csv",
            "files/recording.rrd"} <= downloads
    for href in downloads:  # each download is the artifact itself
        name = href.removeprefix("files/")
        assert (site / "jobs" / by_kind["fit"] / href).read_bytes() == \
            (gallery_jobs.fit / name).read_bytes()
    assert fit.text("pre", id="command-reproduce") == (
        f"inkmotion run --config {gallery_jobs.fit / 'job.json'} "
        "--out results/fit-hi-again")
    assert fit.text("pre", id="command-replay") == (
        f"inkmotion view {gallery_jobs.fit / 'recording.rrd'}")

    store_fit = Page(site / "jobs" / by_kind["fit-store"] / "index.html")
    assert store_fit.text("pre", id="command-replay") == f"inkmotion view {by_kind['fit-store']}"

    evaluation = Page(site / "jobs" / by_kind["evaluate"] / "index.html")
    headers = [t for tag, _, t in evaluation.elements if tag == "th"]
    assert any("msj" in "".join(h).lower() for h in headers)
    assert {"files/speeds.png", "files/minima.png"} <= {a["src"] for a in evaluation.find("img")}

    robot = Page(site / "jobs" / by_kind["simulate"] / "index.html")
    assert "files/sim_drawing.png" in {a["src"] for a in robot.find("img")}

    # jobs made from the fit's plan: its page shows their simulated drawing and evaluation
    # table, theirs link back to it
    assert f"../{by_kind['simulate']}/files/sim_drawing.png" in images | {
        a["src"] for a in fit.find("img")}
    used_by = (site / "jobs" / by_kind["fit"] / "index.html").read_text()
    used_by = used_by[used_by.index('id="used-by"'):]
    assert f"../{by_kind['evaluate']}/index.html" in used_by and "msj" in used_by.lower()
    for page in (evaluation, robot):
        (link,) = page.find("a", id="made-from")
        assert link["href"] == f"../{by_kind['fit']}/index.html"
    assert store_fit.find("a", id="made-from") == []


def test_the_reproduce_command_reproduces_the_job(gallery_jobs, tmp_path):
    build(gallery_jobs, tmp_path / "site")
    job_id = next(i for i, c in cards(tmp_path / "site").items()
                  if c["data-kind"] == "fit" and i.startswith("run-"))
    command = Page(tmp_path / "site" / "jobs" / job_id / "index.html").text(
        "pre", id="command-reproduce")
    args = command.split()[1:]
    args[args.index("--out") + 1] = str(tmp_path / "again")
    res = inkmotion_cli(*args, "--no-record")
    assert res.returncode == 0, res.stderr
    again = json.loads((tmp_path / "again" / "plan.json").read_text())
    assert again == json.loads((gallery_jobs.fit / "plan.json").read_text())


def test_links_are_relative_and_nothing_is_external(gallery_jobs, tmp_path):
    build(gallery_jobs, tmp_path / "site")
    site = tmp_path / "site"
    pages = list(site.rglob("*.html"))
    assert len(pages) == 9
    for page in pages:
        html = page.read_text()
        assert not re.search(r"""(src|href)=["'](https?:|//|/)""", html), page
        for tag, attrs, _ in Page(page).elements:
            link = attrs.get("src") or attrs.get("href")
            if tag in ("a", "img", "link", "script") and link and not link.startswith("#"):
                assert (page.parent / link).resolve().is_file(), (page, link)


def test_rebuild_is_incremental(gallery_jobs, tmp_path):
    site = tmp_path / "site"
    first = build(gallery_jobs, site)
    assert len(first.built) == 8 and first.unchanged == 0
    again = build(gallery_jobs, site)
    assert again.built == [] and again.unchanged == 8 and again.removed == []

    # a running job advances: only its page is rebuilt
    running = gallery_jobs.ids["running"]
    store.update_progress(running, 5, 8, db_url=gallery_jobs.db_url, owner="a1",
                          lease_s=3600)
    moved = build(gallery_jobs, site)
    assert moved.built == [running] and moved.unchanged == 7
    assert 'title="step 5 of 8"' in (site / "index.html").read_text()

    # one more results folder: one page more
    extra = tmp_path / "more"
    shutil.copytree(gallery_jobs.fit, extra / "fit-copy")
    entries = collect(store=True, folders=[gallery_jobs.results, extra],
                      db_url=gallery_jobs.db_url)
    added = build_gallery(entries, site)
    assert len(added.built) == 1 and added.unchanged == 8 and added.jobs == 9

    # a job gone from the sources: its page goes too
    gone = build(gallery_jobs, site)
    assert len(gone.removed) == 1 and gone.removed[0].startswith("run-fit-copy-")
    assert not (site / "jobs" / gone.removed[0]).exists()
    assert len(cards(site)) == 8

    # --full, or a change of templates, rebuilds every page
    assert len(build(gallery_jobs, site, full=True).built) == 8
    mine = tmp_path / "templates"
    mine.mkdir()
    (mine / "index.html.j2").write_text(
        '{% extends "base.html.j2" %}{% block main %}<p id="mine">{{ cards | length }} '
        'of my jobs</p>{% endblock %}')
    custom = build(gallery_jobs, site, templates=mine)
    assert len(custom.built) == 8
    assert Page(site / "index.html").text("p", id="mine") == "8 of my jobs"


def test_a_damaged_job_is_shown_and_the_build_goes_on(gallery_jobs, tmp_path):
    broken = tmp_path / "results" / "broken"
    shutil.copytree(gallery_jobs.fit, broken)
    (broken / "report.json").write_text('{"metrics": ')  # cut short
    (broken / "overlay.png").write_bytes(b"not a png")
    report = build_gallery(collect(store=False, folders=[broken.parent]), tmp_path / "site")
    assert report.jobs == 1 and len(report.problems) == 1
    assert "report.json is unreadable" in report.problems[0]
    page = (tmp_path / "site" / "jobs" / report.built[0] / "index.html").read_text()
    assert "report.json is unreadable" in page


@pytest.mark.parametrize("case, message", [
    ("out-is-file", "is a file; give a folder for the gallery"),
    ("out-is-foreign", "holds files that are not an inkmotion gallery"),
    ("from-missing", "no such folder"),
    ("from-empty", "no results in it"),
    ("templates-missing", "is not a folder"),
])
def test_bad_input_is_one_clear_sentence(gallery_jobs, tmp_path, case, message):
    out = tmp_path / "site"
    folders = [gallery_jobs.results]
    templates = None
    if case == "out-is-file":
        out.write_text("x")
    elif case == "out-is-foreign":
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    elif case == "from-missing":
        folders = [tmp_path / "nowhere"]
    elif case == "from-empty":
        (tmp_path / "empty").mkdir()
        folders = [tmp_path / "empty"]
    else:
        templates = tmp_path / "no-templates"
    with pytest.raises(SpecError, match=message):
        build_gallery(collect(store=False, folders=folders), out, templates=templates)
    if case == "out-is-foreign":
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]  # left untouched


def test_an_unreachable_store_is_named(tmp_path):
    url = "postgresql+psycopg://inkmotion:secret@127.0.0.1:9/jobs?connect_timeout=2"
    pytest.importorskip("psycopg")
    with pytest.raises(ServiceError, match=r"postgresql\+psycopg://inkmotion:\*\*\*@127.0.0.1:9"
                       r"/jobs.* cannot be read .*--no-store --from DIR"):
        collect(db_url=url)


def test_command_line_build_and_serve(gallery_jobs, tmp_path):
    site = tmp_path / "site"
    env = {"INKMOTION_DB_URL": gallery_jobs.db_url,
           "INKMOTION_DATA_DIR": str(gallery_jobs.data_dir)}
    res = inkmotion_cli("gallery", "build", "--from", str(gallery_jobs.results), "--out",
                        str(site), env=env)
    assert res.returncode == 0, res.stderr
    assert "gallery: 8 jobs (8 built, 0 unchanged, 0 removed)" in res.stdout
    assert (site / "index.html").as_uri() in res.stdout
    assert "warning" in res.stdout and gallery_jobs.ids["missing"] in res.stdout
    res = inkmotion_cli("gallery", "build", "--from", str(gallery_jobs.results), "--out",
                        str(site), env=env)
    assert "(0 built, 8 unchanged" in res.stdout

    bad = inkmotion_cli("gallery", "build", "--no-store", "--from", str(tmp_path / "none"),
                        "--out", str(site))
    assert bad.returncode == 1 and bad.stderr.strip().count("\n") == 0
    assert "no such folder" in bad.stderr

    script = Path(sys.executable).with_name("inkmotion")
    server = subprocess.Popen([str(script), "gallery", "serve", "--out", str(site), "--port",
                               "0"], stdout=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/", line).group(0)
        deadline = time.monotonic() + 10
        while True:
            try:
                html = urllib.request.urlopen(url + "index.html", timeout=5).read().decode()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        assert 'id="cards"' in html
    finally:
        server.terminate()
        server.wait(10)
    missing = inkmotion_cli("gallery", "serve", "--out", str(tmp_path / "nothing"))
    assert missing.returncode == 2 and "build it first" in missing.stderr


@pytest.mark.services
def test_jobs_run_by_real_workers_are_in_the_gallery(workers, service_env, tmp_path):
    """Submitted through Redis, run by Celery workers, recorded in the store: the gallery
    built from the store and the data directory shows them, pages and files."""
    words = tmp_path / "words.txt"
    words.write_text("ok\nyes\n")
    res = inkmotion_cli("submit", "fit", "--batch-words", str(words), "--steps", "4",
                        "--size", "64", "--json")
    assert res.returncode == 0, res.stderr
    ids = [j["id"] for j in json.loads(res.stdout)]
    assert len(ids) == 2
    waited = inkmotion_cli("jobs", "wait", *ids, "--timeout", "120", "--quiet", timeout=150)
    assert waited.returncode == 0, waited.stderr
    site = tmp_path / "site"
    built = inkmotion_cli("gallery", "build", "--out", str(site))
    assert built.returncode == 0, built.stderr
    shown = cards(site)
    for job_id in ids:
        assert shown[job_id]["data-status"] == "succeeded"
        page = Page(site / "jobs" / job_id / "index.html")
        assert page.text("pre", id="command-replay") == f"inkmotion view {job_id}"
        artifacts = Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "artifacts"
        assert page.text("pre", id="command-reproduce").startswith(
            f"inkmotion run --config {artifacts / 'job.json'} --out results/{job_id[:8]}")
        assert (site / "jobs" / job_id / "files" / "plan.json").read_bytes() == \
            (artifacts / "plan.json").read_bytes()
        assert (site / "jobs" / job_id / "thumb.png").is_file()


def test_a_page_is_rebuilt_when_a_job_made_from_its_plan_goes(gallery_jobs, tmp_path):
    results = tmp_path / "results"
    for name in ("fit-hi", "fit-hi-eval"):
        shutil.copytree(gallery_jobs.results / name, results / name)
    site = tmp_path / "site"
    first = build_gallery(collect(store=False, folders=[results]), site)
    (fit_id,) = [i for i in first.built if i.startswith("run-fit-hi-") and "eval" not in i]
    assert 'id="used-by"' in (site / "jobs" / fit_id / "index.html").read_text()
    # a later run with the same plan bytes does not take the evaluation over
    time.sleep(0.05)
    shutil.copytree(results / "fit-hi", results / "fit-hi-later")
    (results / "fit-hi-later" / "job.json").touch()
    later = build_gallery(collect(store=False, folders=[results]), site)
    assert len(later.built) == 1 and later.built[0].startswith("run-fit-hi-later-")
    shutil.rmtree(results / "fit-hi-eval")
    second = build_gallery(collect(store=False, folders=[results]), site)
    assert second.built == [fit_id] and len(second.removed) == 1
    assert 'id="used-by"' not in (site / "jobs" / fit_id / "index.html").read_text()


def _card_text(site: Path, job_id: str) -> str:
    """The words of one card's figures on the index (their HTML without the tags)."""
    html = (site / "index.html").read_text(encoding="utf-8")
    start = html.index('<dl class="figures">', html.index(f'data-id="{job_id}"'))
    card = html[start:html.index("</dl>", start)]
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", card)).replace("&amp;", "&")


def test_every_kind_labels_its_figures_in_words(gallery_jobs, tmp_path):
    site = tmp_path / "site"
    build(gallery_jobs, site)
    by_kind = {c["data-kind"]: c["data-id"] for c in cards(site).values()
               if c["data-status"] == "succeeded" and c["data-id"].startswith("run-")}
    sim_report = json.loads((gallery_jobs.results / "fit-hi-robot" / "report.json").read_text())
    sim = _card_text(site, by_kind["simulate"])
    # the job's run time and the arm's motion time are two figures, each named, with units
    assert "run time" in sim and f"motion time {sim_report['duration_s']:.3g} s" in sim, sim
    assert "duration s" not in sim and "tracking RMS, pen down" in sim and " mm" in sim
    assert "drawn in contact" in sim and "%" in sim
    fit = _card_text(site, by_kind["fit"])
    assert "Chamfer max" in fit and " px" in fit and "T_end after / before" in fit
    evaluation = _card_text(site, by_kind["evaluate"])
    assert "minimum jerk / ΣΛ, MSJ" in evaluation and "_ratio" not in evaluation
    for kind, job_id in by_kind.items():  # no report key (``x_mm``) names a figure
        assert not re.search(r"\b[a-z]+_[a-z_]+\b", _card_text(site, job_id).replace(
            "T_end", "")), (kind, _card_text(site, job_id))

    page = Page(site / "jobs" / by_kind["simulate"] / "index.html")
    rows = [(tag, "".join(text).strip()) for tag, _, text in page.elements
            if tag in ("th", "td", "span")]
    words = " ".join(t for _, t in rows)
    assert "IK position error, max" in words and "simulation speed" in words
    html = (site / "jobs" / by_kind["simulate"] / "index.html").read_text(encoding="utf-8")
    # a parameter's special value says what it means, from the parameter's own help
    assert re.search(r"<code>v_max</code></th><td>0 <span class=\"meaning\">— the setup's",
                     html.replace("&#39;", "'")), html
    heads = [("".join(t)).strip() for tag, _, t in Page(
        site / "jobs" / by_kind["evaluate"] / "index.html").elements if tag == "th"]
    assert "MSJ, m²/s⁶" in heads and "duration, s" in heads


def test_figure_labels_and_value_meanings() -> None:
    from inkmotion.gallery import summary

    assert summary.figure("duration_s", 23.47, "simulate") == ("motion time", "23.5 s")
    assert summary.figure("estimated_s", 42.72, "plot") == ("plot time, estimated", "42.7 s")
    assert summary.figure("v_max", 100.0, "plot") == ("feed limit", "100 mm/s")
    assert summary.figure("v_max", 0.25, "evaluate") == ("speed limit", "0.25 m/s")
    assert summary.figure("time-optimal_duration_ratio", 0.329) == (
        "time-optimal / ΣΛ, duration", "0.329×")
    assert summary.figure("tracking_up_3d_max_mm", 1.5) == ("tracking up 3d max", "1.5 mm")
    assert summary.figure("real_time_factor", 44.4) == ("simulation speed", "44.4× real time")
    assert summary.value_meaning("Pen speed limit, m/s (0: the setup's).", 0.0) == \
        "the setup's"
    assert summary.value_meaning("Which path (0-based); -1: every path (the longest "
                                 "plotted).", -1) == "every path (the longest plotted)"
    assert summary.value_meaning("Pen speed limit, m/s (0: the setup's).", 0.3) is None
    assert summary.value_meaning("Setup TOML; empty: the shipped default.", "") == \
        "the shipped default"


def test_a_job_s_warnings_and_random_clip_weights_are_on_its_page(gallery_jobs, tmp_path):
    """The report's warnings reached a job page only for a poor fit, and a result made with
    random CLIP weights (a test result) looked like any other: "CLIP similarity 0.726"."""
    folder = tmp_path / "results" / "random"
    shutil.copytree(gallery_jobs.fit, folder)
    report = json.loads((folder / "report.json").read_text())
    report.update(clip_weights="random", warnings=["Δt of 3 of 8 overlaps sits on its bound"])
    (folder / "report.json").write_text(json.dumps(report))
    build_gallery(collect(store=False, folders=[tmp_path / "results"]), tmp_path / "site")
    (job_id, card), = cards(tmp_path / "site").items()
    assert "random-weights" in card["data-search"]
    index = (tmp_path / "site" / "index.html").read_text()
    assert "random CLIP weights: a test result" in index
    page = Page(tmp_path / "site" / "jobs" / job_id / "index.html").all_text
    assert "Δt of 3 of 8 overlaps sits on its bound" in page
    assert "random CLIP weights: a test result" in page
