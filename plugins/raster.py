"""The built-in 'raster' renderer: a differentiable anti-aliased stroke rasterizer.

Cubic segments are cut into short chords, each drawn as a capsule of radius r with the
anti-aliased coverage clamp(r + ½ − d, 0, 1), united by a per-pixel max. Segments (S, 4, 2)
come with widths (S,), r = w/2; segments (S, 4, 3) carry the radius in px as their third
coordinate (widths ignored) and the width varies along the stroke. The implementation
lives in :mod:`inkmotion.rendering.raster`; this module is the plugin's registration only
and imports no torch, so listing plugins stays fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import Renderer
    from inkmotion.rendering.raster import RasterSession


class RasterRenderer:
    """The 'raster' renderer plugin object (:mod:`inkmotion.rendering.raster`)."""

    name = "raster"
    description = "Differentiable anti-aliased stroke rasterizer (plain PyTorch, CPU and CUDA)."
    #: its sessions draw several drawings per call (a batched fit)
    renders_canvases = True

    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int
    ) -> torch.Tensor:
        """Coverage image (H, W) in [0, 1] of cubic segments (S, 4, 2) with widths (S,), or
        (S, 4, 3) whose third coordinate is the radius in px (widths then ignored); checks
        its input (ValueError on NaN or a negative width or radius) and sizes itself from
        the data."""
        from inkmotion.rendering.raster import render_segments

        return render_segments(segments, widths, height, width)

    def session(self, device: torch.device | str, static: bool | None = None) -> RasterSession:
        """A renderer for the many calls of one fit, without value checks (the fit checks
        its loss): static shapes and no device read on an accelerator, sized per call on the
        CPU (where reading the device is free), unless ``static`` says otherwise."""
        from inkmotion.rendering.raster import RasterSession

        if static is None:
            static = str(device).split(":")[0] != "cpu"
        return RasterSession(static=static, check=False)


@hookimpl
def inkmotion_renderers() -> list[Renderer]:
    """The built-in renderers of this module."""
    return [RasterRenderer()]
