"""``inkmotion gallery``: build the static gallery of every job, and serve it.

``build`` reads the job store (``INKMOTION_DB_URL``) and any results folders given with
``--from``, and writes the site (:mod:`inkmotion.gallery`); ``serve`` serves a built one
on localhost with Python's ``http.server``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError

out = Console()

GALLERY_HELP = """Browse every job in a browser: a static site with a card per job.

Examples:

  inkmotion gallery build                     # the job store -> <data dir>/gallery

  inkmotion gallery build --from results --out site     # + folders of `inkmotion run`

  inkmotion gallery build --no-store --from gallery/out --out gallery/site

  inkmotion gallery serve --out site --port 8000
"""

gallery_app = typer.Typer(help=GALLERY_HELP, no_args_is_help=True, rich_markup_mode="rich")

OutOpt = Annotated[Optional[Path], typer.Option(  # noqa: UP045
    "--out", help="The site's folder (default: <data dir>/gallery).")]


def _default_out() -> Path:
    from inkmotion.settings import load_settings

    return load_settings().data_dir / "gallery"


@gallery_app.command("build")
def build_cmd(
    out_dir: OutOpt = None,
    folders: Annotated[Optional[list[Path]], typer.Option(  # noqa: UP045
        "--from", help="Also show the results folders (written by `inkmotion run --out`) "
                       "at or under this folder; repeatable.")] = None,
    store: Annotated[bool, typer.Option(
        "--store/--no-store", help="Show the job store's jobs (INKMOTION_DB_URL).")] = True,
    full: Annotated[bool, typer.Option(
        "--full", help="Rebuild every page, not only new or changed jobs.")] = False,
    templates: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--templates", help="A folder of your own templates (index.html.j2, job.html.j2, "
                            "...), used instead of the built-in ones of the same name.")
    ] = None,
    title: Annotated[str, typer.Option(help="The index page's title.")] = "inkmotion gallery",
) -> None:
    """Build the gallery (incrementally: only new or changed jobs are rebuilt).

    Examples:

      inkmotion gallery build

      inkmotion gallery build --from results --out site --title "My tags"

      inkmotion gallery build --no-store --from results --out site --full
    """
    from tqdm import tqdm

    from inkmotion.gallery import build_gallery, collect

    target = out_dir or _default_out()
    try:
        entries = collect(store=store, folders=folders or [])
        with tqdm(total=len(entries), desc="gallery", unit="job", leave=False,
                  disable=None) as bar:
            report = build_gallery(entries, target, templates=templates, full=full,
                                   title=title, on_job=lambda e, rebuilt: bar.update(1))
    except InkmotionError as exc:
        fail(exc)
    for problem in report.problems:
        out.print(f"[yellow]warning[/]: {problem}", highlight=False, soft_wrap=True)
    out.print(f"gallery: {report.jobs} jobs ({len(report.built)} built, {report.unchanged} "
              f"unchanged, {len(report.removed)} removed) in {report.seconds:.2f} s\n"
              f"open {report.index.as_uri()}", highlight=False, soft_wrap=True)


@gallery_app.command("serve")
def serve_cmd(
    out_dir: OutOpt = None,
    port: Annotated[int, typer.Option(help="Port on 127.0.0.1 (0: any free one).")] = 8000,
) -> None:
    """Serve a built gallery on http://127.0.0.1:PORT until Ctrl-C.

    The site also opens from file:// (its index.html); serve it to see it as a static web
    host shows it. Any static server works the same (nginx, `python -m http.server`).

    Example: inkmotion gallery serve --out site --port 8000
    """
    import functools
    import http.server

    site = out_dir or _default_out()
    if not (site / "index.html").is_file():
        fail(f"{site} holds no gallery (no index.html); build it first with "
             f"`inkmotion gallery build --out {site}`.", code=2)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    try:
        server = http.server.ThreadingHTTPServer(("127.0.0.1", port), handler)
    except OSError as exc:
        fail(f"Cannot serve on 127.0.0.1:{port} ({exc.strerror}); choose another --port.",
             code=2)
    out.print(f"serving {site} at http://127.0.0.1:{server.server_address[1]}/ (Ctrl-C stops)",
              highlight=False, soft_wrap=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()


def register(app: typer.Typer) -> None:
    """Add ``gallery`` to the ``inkmotion`` app."""
    app.add_typer(gallery_app, name="gallery")
