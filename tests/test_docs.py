"""The docs/ tree stays true to the code: the CLI reference is the generator's output, every
relative link resolves, nothing in the project points outside the repository, and the key
and column tables of docs/formats.md match what the code writes (the golden reports of
tests/data/v4_jobs, a real plot job, the shipped setup file, the machine profile's fields,
a real trajectory.csv)."""

from __future__ import annotations

import dataclasses
import difflib
import fnmatch
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FORMATS = DOCS / "formats.md"
GOLDEN = ROOT / "tests" / "data" / "v4_jobs"
#: project files that must not refer to anything outside the repository
PROJECT = ("framework", "plugins", "workers", "gallery", "docs", "README.md", "Makefile",
           "pyproject.toml")
#: what such a reference looks like: the design notes, the shared folder, this machine's tree
OUTSIDE = re.compile(r"DESIGN\.md|\.\./shared|(?<![\w.~-])/work(?:/|\b)")
TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt", ".cfg", ".ini", ".yml", ".yaml", ".json",
                 ".j2", ".html", ".css", ".js", ".mako", ".service", ".sh", ""}
#: report keys that are clock readings: the golden reports were not compared on them
#: (tests/test_golden_jobs.py), so a golden report may predate one
CLOCK = {"wall_s", "fit_s", "s_per_step", "threads", "device", "checkpoints"}


def run_python(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "INKMOTION_DISABLE_PLUGINS"}
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


# --- the CLI reference -------------------------------------------------------------------
@pytest.fixture(scope="module")
def generated() -> str:
    out = run_python("-m", "inkmotion.cli.reference")
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_the_cli_reference_is_the_generators_output(generated: str) -> None:
    written = (DOCS / "cli.md").read_text(encoding="utf-8")
    if written != generated:
        diff = "".join(list(difflib.unified_diff(
            written.splitlines(True), generated.splitlines(True), "docs/cli.md",
            "python -m inkmotion.cli.reference"))[:40])
        pytest.fail("docs/cli.md is out of date: run `make docs` (or `python -m "
                    f"inkmotion.cli.reference > docs/cli.md`).\n{diff}")


def test_the_cli_reference_lists_the_projects_own_plugins_only(generated: str) -> None:
    from inkmotion.cli.reference import DISTRIBUTION, own_plugins
    from inkmotion.plugin_host import host

    foreign = [r for r in host().table()
               if r.error is None and r.origin.split(" ", 1)[0] != DISTRIBUTION]
    if not foreign:
        pytest.skip("no third-party plugin is installed (make test-venv installs two)")
    for row in foreign:
        assert f"### {row.name}\n" not in generated, row
        assert f"`--{row.name}-" not in generated, row
        assert f"| `{row.name}` |" not in generated, row
    for kind in own_plugins()["job-kind"]:
        assert f"\n### {kind}\n" in generated, kind


def test_the_cli_reference_names_the_own_plugins_of_every_plugin_kind(generated: str) -> None:
    """Each plugin parameter's allowed values list that kind's own plugins (the tracer's
    list was empty while the reference knew plugin kinds of its own, not the hooks')."""
    from inkmotion.cli.reference import own_plugins
    from inkmotion.plugin_host.hookspecs import KIND_HOOKS

    plugins = own_plugins()
    assert set(plugins) == set(KIND_HOOKS)
    for kind in ("tracer", "reader", "initialiser", "image-loss", "renderer"):
        assert plugins[kind], kind
        assert f"{kind}: `{next(iter(plugins[kind]))}`" in generated, kind


# --- links -----------------------------------------------------------------------------
def _prose(text: str) -> str:
    """Markdown without fenced code blocks and inline code (links there are not links)."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    return re.sub(r"`[^`\n]*`", "", text)


def _links(text: str) -> list[str]:
    return re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", _prose(text))


def anchors(path: Path) -> set[str]:
    """The heading anchors GitHub gives a Markdown file."""
    seen: dict[str, int] = {}
    out = set()
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.S | re.M)
    for heading in re.findall(r"^#{1,6}\s+(.+?)\s*#*$", text, flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def _broken(source: Path, only_under: str | None = None, root: Path = ROOT) -> list[str]:
    """The relative links of ``source`` whose file or heading does not exist (``only_under``:
    only links starting with it), named relative to ``root``."""
    broken = []
    for link in _links(source.read_text(encoding="utf-8")):
        if re.match(r"[a-z][a-z0-9+.-]*:", link) or link.startswith("//"):
            continue  # http:, https:, mailto:
        target, _, anchor = link.partition("#")
        if only_under is not None and not target.startswith(only_under):
            continue
        path = (source.parent / target).resolve() if target else source
        if not path.exists():
            broken.append(f"{source.relative_to(root)}: {link} (no such file)")
        elif anchor and path.suffix == ".md" and anchor not in anchors(path):
            broken.append(f"{source.relative_to(root)}: {link} (no such heading)")
    return broken


def test_every_relative_link_in_the_docs_resolves() -> None:
    pages = sorted(DOCS.rglob("*.md"))
    assert pages, "docs/ holds no pages"
    broken = [b for page in pages for b in _broken(page)]
    broken += _broken(ROOT / "README.md", only_under="docs/")
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_the_index_links_every_page() -> None:
    index = (DOCS / "README.md").read_text(encoding="utf-8")
    linked = {(DOCS / link.partition("#")[0]).resolve() for link in _links(index)}
    missing = [str(p.relative_to(ROOT)) for p in sorted(DOCS.rglob("*.md"))
               if p.name != "README.md" and p.resolve() not in linked]
    assert not missing, f"docs/README.md does not link {missing}"


def test_a_broken_link_is_found(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("# Title\n[ok](#title) [gone](missing.md) [bad](#nowhere)\n"
                    "`[code](not-a-link.md)`\n", encoding="utf-8")
    found = [b.split(": ", 1)[1] for b in _broken(page, root=tmp_path)]
    assert found == ["missing.md (no such file)", "#nowhere (no such heading)"]


# --- nothing outside the repository ------------------------------------------------------
def project_files() -> list[Path]:
    """The project's text files (tracked or new, not ignored) under :data:`PROJECT`."""
    try:
        listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard",
                                 "--", *PROJECT], cwd=ROOT, capture_output=True, text=True,
                                check=True, timeout=60).stdout.splitlines()
        files = [ROOT / name for name in listed]
    except (OSError, subprocess.CalledProcessError):  # not a git checkout
        files = []
        for top in PROJECT:
            base = ROOT / top
            files += [base] if base.is_file() else [
                p for p in base.rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    return [f for f in files if f.is_file() and f.suffix in TEXT_SUFFIXES]


def test_no_project_file_refers_outside_the_repository() -> None:
    files = project_files()
    assert any(f.suffix == ".md" for f in files) and any(f.suffix == ".py" for f in files)
    found = []
    for f in files:
        try:
            text = f.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{f.relative_to(ROOT)}:{n}: {line.strip()[:100]}")
    assert not found, "references outside the repository:\n" + "\n".join(found)


def test_the_outside_pattern_matches_what_it_should() -> None:
    assert OUTSIDE.search("see DESIGN.md") and OUTSIDE.search("../shared/data/gml")
    assert OUTSIDE.search("/work/main/tests") and OUTSIDE.search("cd /work")
    assert not OUTSIDE.search("inkmotion.workers, tests/workers.py, framework/")


# --- the tables of docs/formats.md -------------------------------------------------------
def tables(marker: str) -> dict[str, list[list[str]]]:
    """The table after each ``<!-- MARKER: LABEL -->`` of formats.md: label -> body rows
    (cells, stripped)."""
    out: dict[str, list[list[str]]] = {}
    lines = FORMATS.read_text(encoding="utf-8").splitlines()
    for i, line in enumerate(lines):
        m = re.fullmatch(rf"<!-- {re.escape(marker)}: (.+?) -->", line.strip())
        if not m:
            continue
        body = []
        for row in lines[i + 3:]:  # the header and its rule come first
            if not row.startswith("|"):
                break
            body.append([c.strip() for c in re.split(r"(?<!\\)\|", row.strip())[1:-1]])
        assert body, f"no table after {line}"
        out[m.group(1)] = body
    return out


def documented_keys(kind: str) -> dict[str, str]:
    """The report.json keys formats.md documents for ``kind``: key path -> its "when"."""
    keys: dict[str, str] = {}
    for label, rows in tables("report-keys").items():
        if kind in label.split():
            for row in rows:
                key = re.match(r"`([^`]+)`", row[0])
                assert key, f"a report-keys row without a `key`: {row}"
                keys[key.group(1)] = row[1]
    return keys


def _parent(path: str) -> str:
    return path.rsplit(".", 1)[0] if "." in path else ""


def report_mismatches(report: dict, documented: dict[str, str], prefix: str = "") -> list[str]:
    """Where ``report`` and the documented keys disagree, at every level whose keys the
    docs list: a key the docs do not know, or one they say is always there that is not."""
    level = {k.rsplit(".", 1)[-1]: when for k, when in documented.items()
             if _parent(k) == prefix.rstrip(".")}
    if not level:
        return []
    out = [f"{prefix}{key}: written but not in docs/formats.md" for key in report
           if not any(fnmatch.fnmatchcase(key, pattern) for pattern in level)]
    out += [f"{prefix}{key}: documented as always written, but missing" for key, when in
            level.items() if when.startswith("always") and "*" not in key and key not in report
            and not (prefix == "" and key in CLOCK)]
    for key, value in report.items():
        if isinstance(value, dict):
            out += report_mismatches(value, documented, f"{prefix}{key}.")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            union = {k: v for item in value for k, v in item.items()}
            out += report_mismatches(union, documented, f"{prefix}{key}[].")
    return out


def test_every_kind_has_its_report_table() -> None:
    from inkmotion.cli.reference import own_plugins

    labels = [label.split() for label in tables("report-keys")]
    for kind in own_plugins()["job-kind"]:
        assert [kind] in labels, f"docs/formats.md has no report-keys table of {kind} alone"


@pytest.mark.parametrize("kind", sorted(p.name for p in GOLDEN.iterdir()
                                        if (p / "report.json").is_file()))
def test_the_report_tables_match_the_golden_reports(kind: str) -> None:
    report = json.loads((GOLDEN / kind / "report.json").read_text(encoding="utf-8"))
    assert report["kind"] == kind
    problems = report_mismatches(report, documented_keys(kind))
    assert not problems, f"report.json of {kind} against docs/formats.md:\n" + "\n".join(problems)


def test_the_report_check_finds_an_undocumented_key() -> None:
    documented = {"a": "always", "m": "always", "m.x": "always", "m.y*": "when y",
                  "b": "when b"}
    assert report_mismatches({"a": 1, "m": {"x": 1, "y1": 2}}, documented) == []
    assert report_mismatches({"a": 1, "c": 2, "m": {"z": 3}}, documented) == [
        "c: written but not in docs/formats.md", "m.z: written but not in docs/formats.md",
        "m.x: documented as always written, but missing"]


def test_the_plot_report_matches_its_table(tmp_path: Path) -> None:
    """No golden plot report exists: a real (fast) plot job writes one."""
    out = run_python("-m", "inkmotion", "run", "plot", str(GOLDEN / "fit" / "plan.json"),
                     "--out", str(tmp_path / "plot"), "--no-record")
    assert out.returncode == 0, out.stderr
    report = json.loads((tmp_path / "plot" / "report.json").read_text(encoding="utf-8"))
    problems = report_mismatches(report, documented_keys("plot"))
    assert not problems, "report.json of plot against docs/formats.md:\n" + "\n".join(problems)


def _names(cell: str) -> list[str]:
    """The names in a key or column cell: `a`, `b` … or a range `q1` … `q7`."""
    names = re.findall(r"`([^`]+)`", cell)
    if "…" in cell and len(names) == 2:
        (head, a), (_, b) = (re.fullmatch(r"(\D+)(\d+)", n).groups() for n in names)
        return [f"{head}{i}" for i in range(int(a), int(b) + 1)]
    return names


def test_the_setup_table_lists_the_shipped_setups_keys() -> None:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    from inkmotion.robot.setup import DEFAULT_SETUP

    shipped = tomllib.loads(DEFAULT_SETUP.read_text(encoding="utf-8"))
    keys = [f"{section}.{key}" for section, table in shipped.items() for key in table]
    documented = [n for row in tables("toml-keys")["setup.toml"] for n in _names(row[0])]
    assert documented == keys


def test_the_machine_table_lists_the_machine_fields() -> None:
    from inkmotion.plotter.machine import MACHINES, Machine

    rows = tables("toml-keys")["machine"]
    assert [n for row in rows for n in _names(row[0])] == [f.name for f in
                                                           dataclasses.fields(Machine)]
    grbl = dataclasses.asdict(MACHINES["grbl"])
    for row in rows:  # the defaults column: a custom file's values come from grbl
        (name,) = _names(row[0])
        value = grbl[name]
        if isinstance(value, (int, float)):
            assert re.search(r"[\d.]+", row[2]) and float(re.search(r"[\d.]+", row[2])[0]) \
                == pytest.approx(value), row


def test_the_trajectory_csv_columns_are_the_writers(tmp_path: Path) -> None:
    from inkmotion.outputs.trajectory_csv import write_trajectory_csv
    from inkmotion.sigma_lognormal.plan import MotorPlan

    rows = tables("csv-columns")["trajectory.csv"]
    documented = [n for row in rows for n in _names(row[0])]
    plan = MotorPlan.from_points([[0.0, 0.0], [10.0, 5.0], [20.0, 0.0]])
    for three in (False, True):
        path = tmp_path / f"t{int(three)}.csv"
        write_trajectory_csv(path, [plan.with_radius(1.5) if three else plan])
        header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
        assert header == [c for c in documented if three or c != "r"]
