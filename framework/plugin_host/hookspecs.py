"""Hook specifications: one hook per plugin kind.

Each hook returns a list of plugin objects of that kind. A plugin module (built-in or
third-party) implements one or more of these hooks and is registered through the
``inkmotion`` entry-point group; pluggy verifies the implementation's signature
against the spec at registration time.

The objects returned follow the protocols in :mod:`inkmotion.plugin_host.protocols`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import (
        ImageLoss,
        Initialiser,
        JobKind,
        Reader,
        Renderer,
        RobotBackend,
        Saliency,
        Tracer,
    )

PROJECT = "inkmotion"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def inkmotion_job_kinds() -> list[JobKind]:
    """Job kinds: parameters, queue, steps and ``run(job) -> report`` (fit, tag, ...)."""


@hookspec
def inkmotion_readers() -> list[Reader]:
    """Readers: parse an input (file path or ``scheme:value`` string) into traces."""


@hookspec
def inkmotion_tracers() -> list[Tracer]:
    """Tracers: a picture of a line drawing -> traces (strokes, order, direction, width)."""


@hookspec
def inkmotion_initialisers() -> list[Initialiser]:
    """Initialisers: traces (or an image / caption) -> initial motor plans."""


@hookspec
def inkmotion_image_losses() -> list[ImageLoss]:
    """Image losses: (rendered image, target) -> scalar tensor."""


@hookspec
def inkmotion_renderers() -> list[Renderer]:
    """Renderers: Bézier segments + widths -> differentiable coverage image."""


@hookspec
def inkmotion_saliency() -> list[Saliency]:
    """Saliency estimators: image -> [0, 1] map."""


@hookspec
def inkmotion_robot_backends() -> list[RobotBackend]:
    """Robot backends: timed Cartesian plan -> execution or export."""


#: plugin kind (as users name it) -> the hook that provides plugins of that kind
KIND_HOOKS: dict[str, str] = {
    "job-kind": "inkmotion_job_kinds",
    "reader": "inkmotion_readers",
    "tracer": "inkmotion_tracers",
    "initialiser": "inkmotion_initialisers",
    "image-loss": "inkmotion_image_losses",
    "renderer": "inkmotion_renderers",
    "saliency": "inkmotion_saliency",
    "robot-backend": "inkmotion_robot_backends",
}
