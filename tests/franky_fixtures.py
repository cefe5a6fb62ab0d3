"""franky-sim, the libfranka-protocol simulator of an FR3 on MuJoCo, started by the tests
on loopback like redis-server: ``franky_sim_server(address)`` runs the ``franky-sim``
command (its ports are fixed, 1337 and 1338, so each server takes its own 127.0.0.x
address), and waits until a libfranka client can connect. Tests using it skip when
franky-sim or franky-control is not installed. ``sim_address(k)`` is 127.0.0.k in one
test process and 127.0.0.(k + 10·n) in pytest-xdist's worker n, so the workers' servers
never share an address (a second server on a taken address cannot bind, and its tests
would drive the first worker's arm)."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

READY_TIMEOUT_S = 30.0
#: s a test's own connection to franky-sim may take: libfranka's handshake waits in C++
#: where pytest's timeout cannot end it, so a simulator that accepted the connection and
#: never answered hung the whole run (seen once, in a 3-process run); through
#: ``franka.connect`` it fails in this time, naming the address
CONNECT_S = 30.0


def sim_address(last: int) -> str:
    """A loopback address of this test process's own (module docstring)."""
    import os

    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    n = int(worker[2:]) if worker[2:].isdigit() else 0
    return f"127.0.0.{last + 10 * n}"


def franky_sim_binary() -> str | None:
    here = Path(sys.executable).with_name("franky-sim")
    return str(here) if here.exists() else shutil.which("franky-sim")


def require_franky() -> None:
    pytest.importorskip("franky", reason="franky-control is not installed")
    if franky_sim_binary() is None:
        pytest.skip("franky-sim is not installed (pip install franky-sim)")


@contextmanager
def franky_sim_server(address: str, log: Path) -> Iterator[subprocess.Popen]:
    """A franky-sim process serving the FCI at ``address`` until the block ends."""
    require_franky()
    from inkmotion.errors import ServiceError
    from inkmotion.robot.franka import connect, scheduling_kept

    with open(log, "wb") as out:
        proc = subprocess.Popen([franky_sim_binary(), "-s", "mujoco", "--hostname", address],
                                stdout=out, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + READY_TIMEOUT_S
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"franky-sim exited: {log.read_text(errors='replace')}")
            try:  # in a thread that gives up (CONNECT_S), not in libfranka's handshake
                with scheduling_kept():
                    robot = connect(address, realtime=False,
                                    timeout=min(CONNECT_S, READY_TIMEOUT_S / 3))
                    del robot
                break
            except ServiceError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
