"""A job's rerun recording in rerun's own web viewer, served by the ``rerun`` binary.

``rerun --serve-web RECORDING`` hosts the viewer over HTTP and the recording over gRPC, both
on loopback and on ports picked free here; the page opens the viewer's address, which names
the gRPC one. One viewer at a time: opening another recording stops the last, and so does
the studio's end. The viewer is reachable from this machine only (its ports listen on
loopback whatever the studio's ``--host``); elsewhere, download recording.rrd.

The ``rerun`` binary sends usage statistics unless its config file says not to (it reads
no environment switch but ``CI``); the studio's viewer runs with a config folder of its
own whose ``analytics.json`` turns them off (:func:`quiet_env`), so serving a recording
sends nothing anywhere and leaves the user's own rerun settings as they are.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
import threading
import time
import urllib.parse
import urllib.request
from pathlib import Path

from inkmotion.errors import ServiceError

#: seconds the viewer may take to answer over HTTP
START_TIMEOUT_S = 20.0


class RerunViewer:
    """The one ``rerun --serve-web`` process of the studio (module docstring)."""

    def __init__(self) -> None:
        self._proc: subprocess.Popen | None = None
        self._lock = threading.Lock()
        self._config: tempfile.TemporaryDirectory | None = None

    def _home(self) -> Path:
        """The viewer's own config folder (made once, removed with the studio's end)."""
        if self._config is None:
            self._config = tempfile.TemporaryDirectory(prefix="inkmotion-rerun-")
        return Path(self._config.name)

    def open(self, recording: Path) -> str:
        """Serve ``recording``; the viewer's address. :class:`ServiceError` (one sentence)
        when the binary is missing or does not answer."""
        from inkmotion.recording import rerun_binary
        from inkmotion.workers.local import HOST, free_port

        binary = rerun_binary()
        if binary is None:
            raise ServiceError("The rerun viewer is not installed beside inkmotion; "
                               "`pip install rerun-sdk` gives it, or download recording.rrd.")
        with self._lock:
            self.close()
            grpc, web = free_port(), free_port()
            env = quiet_env(self._home())
            self._proc = subprocess.Popen(
                [binary, "--serve-web", "--bind", HOST, "--port", str(grpc),
                 "--web-viewer-port", str(web), str(recording)],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                start_new_session=True)
            url = f"http://{HOST}:{web}/"
            deadline = time.monotonic() + START_TIMEOUT_S
            while time.monotonic() < deadline:
                if self._proc.poll() is not None:
                    break
                try:
                    urllib.request.urlopen(url, timeout=1).close()
                    source = urllib.parse.quote(f"rerun+http://{HOST}:{grpc}/proxy", safe="")
                    return f"{url}?url={source}"
                except OSError:
                    time.sleep(0.2)
            self.close()
            raise ServiceError("The rerun web viewer did not start; open recording.rrd with "
                               "`inkmotion view` instead.")

    def close(self) -> None:
        """Stop the viewer (its whole process group), if one runs."""
        from inkmotion.workers.local import stop_process

        proc, self._proc = self._proc, None
        if proc is not None:
            stop_process(proc, grace=5)


def quiet_env(home: Path) -> dict[str, str]:
    """This process's environment for a ``rerun`` binary whose config and data folders lie
    in ``home``, with an ``analytics.json`` there that turns its usage statistics off
    (where the binary looks for it: XDG folders on Linux, ``~/Library/Application
    Support`` on macOS, the app-data folders on Windows)."""
    for folder in (home / "config" / "rerun",  # under XDG_CONFIG_HOME, HOME and APPDATA
                   home / "Library" / "Application Support" / "rerun",
                   home / "AppData" / "Roaming" / "rerun" / "config"):
        folder.mkdir(parents=True, exist_ok=True)
        config = {"analytics_enabled": False, "analytics_id": "inkmotion-studio",
                  "metadata": {}, "config_file_path": str(folder / "analytics.json"),
                  "data_dir_path": str(home / "data" / "rerun" / "analytics")}
        (folder / "analytics.json").write_text(json.dumps(config))
    return {**os.environ, "XDG_CONFIG_HOME": str(home / "config"),
            "XDG_DATA_HOME": str(home / "data"), "HOME": str(home),
            "APPDATA": str(home / "AppData" / "Roaming"),
            "LOCALAPPDATA": str(home / "AppData" / "Local")}
