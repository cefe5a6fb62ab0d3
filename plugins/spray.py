"""The built-in 'spray' renderer: spray paint from the ΣΛ speed (the paper's Fig. 3b).

As a renderer (``--renderer spray``) it is the differentiable expected paint density:
speed-weighted Gaussian splats along every cubic segment, no randomness, on any device
(:mod:`inkmotion.rendering.spray`). ``inkmotion render PLAN --renderer spray`` also
gives the seeded preview with particles and drips
(:mod:`inkmotion.rendering.spray_preview`). This module is the plugin's registration only
and imports no torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import Renderer


class SprayRenderer:
    """The 'spray' renderer plugin object."""

    name = "spray"
    description = ("Spray paint: expected density of speed-weighted Gaussian splats "
                   "(differentiable, CPU and CUDA); seeded particles and drips in previews.")
    #: its paint is denser where the pen slows: an image loss through it depends on the
    #: timing, so a fit keeps the lognormals' shapes fixed with it (kinds/fit.py)
    paints_by_speed = True

    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int
    ) -> torch.Tensor:
        """Coverage (H, W) in [0, 1) of the expected spray paint of cubic segments
        (S, 4, 2) with widths (S,), or (S, 4, 3) with the radius as third coordinate."""
        import torch

        from inkmotion.rendering.spray import render_spray

        if not bool(torch.isfinite(segments).all()):
            raise ValueError("the segments hold NaN or infinite coordinates")
        return render_spray(segments, widths, height, width)

    def session(self, device: torch.device | str, static: bool | None = None) -> object:
        """A renderer for the many calls of one fit: no value checks and the splat patch
        sized once, on the first call (:class:`inkmotion.rendering.spray.SpraySession`)."""
        from inkmotion.rendering.spray import SpraySession

        return SpraySession()


@hookimpl
def inkmotion_renderers() -> list[Renderer]:
    """The built-in renderers of this module."""
    return [SprayRenderer()]
