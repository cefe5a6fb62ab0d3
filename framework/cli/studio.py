"""``inkmotion studio``: the whole pipeline in a browser (:mod:`inkmotion.studio`), served
by uvicorn on loopback; on any other address only with a token, printed once."""

from __future__ import annotations

import ipaddress
import secrets
import threading
import webbrowser
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import EXIT_USAGE, fail

#: the studio's port unless --port says otherwise
DEFAULT_PORT = 8765
#: the fewest characters a --token may have off loopback, where it is all that guards
MIN_TOKEN = 16
#: seconds Ctrl-C waits for open pages (a fit's event stream never ends by itself) before
#: closing them and cancelling the jobs that run here
GRACE_S = 3


def is_loopback(host: str) -> bool:
    """Whether ``host`` is this machine only (``localhost``, 127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def studio_cmd(
    host: Annotated[str, typer.Option(
        help="Address to listen on; any other than loopback needs the token it prints "
             "(or --token).")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on (0: a free one).")] = DEFAULT_PORT,
    token: Annotated[Optional[str], typer.Option(  # noqa: UP045
        help="The secret every request must carry; default: none on loopback, a new random "
             "one otherwise.")] = None,
    workers: Annotated[bool, typer.Option(
        "--workers", help="Queue jobs for the Celery workers (INKMOTION_BROKER_URL) instead "
                          "of running them in this process.")] = False,
    slots: Annotated[int, typer.Option(
        help="Jobs run at once in this process (0: the cores over a job's threads).")] = 0,
    open_browser: Annotated[bool, typer.Option(
        "--open/--no-open", help="Open the studio in the default browser.")] = True,
) -> None:
    """Open the studio: draw, drop or pick a drawing, watch its motion fit and move at its
    real speed, and send it to a plotter, the arm or the queue.

    Jobs are recorded in the job store (INKMOTION_DB_URL) with their files under the data
    directory (INKMOTION_DATA_DIR), like submitted ones: `inkmotion jobs list` shows them.

    Examples:

      inkmotion studio

      inkmotion studio --port 9000 --no-open

      inkmotion studio --host 0.0.0.0 --workers    # on the LAN, jobs to the workers
    """
    import uvicorn

    from inkmotion.errors import InkmotionError
    from inkmotion.settings import load_settings
    from inkmotion.studio.app import create_app

    if token is None and not is_loopback(host):
        token = secrets.token_urlsafe(18)
    elif token is not None and not is_loopback(host) and len(token) < MIN_TOKEN:
        fail(f"--token: on {host} the token is all that guards the studio, and one of "
             f"{len(token)} characters is soon guessed; give one of {MIN_TOKEN} or more, or "
             "leave --token out for a random one.", code=EXIT_USAGE)
    _check_port(host, port)  # before any job process starts
    try:
        settings = load_settings()
        if workers:
            from inkmotion.workers.submit import check_broker

            check_broker(settings)
        app = create_app(settings, token=token, workers=workers, slots=slots or None)
    except InkmotionError as exc:
        fail(exc)
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", access_log=False,
                            timeout_graceful_shutdown=GRACE_S)
    server = uvicorn.Server(config)
    err = Console(stderr=True, highlight=False)

    def announce() -> None:  # once the socket listens: the real port (--port 0) is known
        while not server.started:
            if server.should_exit:
                return
            threading.Event().wait(0.05)
        bound = server.servers[0].sockets[0].getsockname()[1] if server.servers else port
        shown = "localhost" if is_loopback(host) else host
        url = f"http://{shown}:{bound}/" + (f"?token={token}" if token else "")
        err.print(f"inkmotion studio at {url}  (jobs in {settings.data_dir}; Ctrl-C stops)")
        if open_browser:
            webbrowser.open(url)

    threading.Thread(target=announce, daemon=True).start()
    server.run()


def _check_port(host: str, port: int) -> None:
    """One sentence, before uvicorn starts, when ``host:port`` cannot be listened on."""
    import socket

    if port == 0:
        return
    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        with socket.socket(family) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host, port))
    except OSError as exc:
        fail(f"cannot listen on {host}:{port} ({exc.strerror}); choose another port with "
             "--port or stop what uses it.")


def register(app: typer.Typer) -> None:
    """Add ``studio`` to the ``inkmotion`` app."""
    app.command("studio")(studio_cmd)
