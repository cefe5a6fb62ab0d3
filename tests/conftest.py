"""Shared fixtures: the real services (redis-server, Celery workers) live in service_fixtures;
``device`` runs a test on the CPU and, where there is one, on CUDA (kornia-style)."""

from __future__ import annotations

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
