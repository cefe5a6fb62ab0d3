"""Shared fixtures: the real services (redis-server, Celery workers) live in service_fixtures;
``device`` runs a test on the CPU and, where there is one, on CUDA (kornia-style)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
import torch

pytest_plugins = ["service_fixtures", "gallery_fixtures"]


@pytest.fixture(params=[
    "cpu",
    pytest.param("cuda", marks=pytest.mark.skipif(not torch.cuda.is_available(),
                                                   reason="CUDA not available")),
])
def device(request: pytest.FixtureRequest) -> torch.device:
    """The device a model, renderer or loss test runs on."""
    return torch.device(request.param)


@pytest.fixture(autouse=True)
def _scheduling_left_alone() -> Iterator[None]:
    """No test may leave the test process at another scheduling policy: libfranka raises
    the thread that talks to a robot to SCHED_FIFO 99, and the worker processes of every
    later test would inherit it and busy-wait each other to a standstill."""
    if not hasattr(os, "sched_getscheduler"):  # pragma: no cover - macOS, Windows
        yield
        return
    before = os.sched_getscheduler(0), os.sched_getparam(0)
    yield
    assert (os.sched_getscheduler(0), os.sched_getparam(0)) == before, (
        "this test left the test process at another scheduling policy (libfranka's "
        "SCHED_FIFO?); wrap the robot calls in inkmotion.robot.franka.scheduling_kept()")
