"""Image loss "mse": the paper's multi-scale mean squared error (eq. "mse").

    L_I = Σ_s MSE(I_s, Î_s),   I_{s+1} = downscale_½(blur_σ=1(I_s)),  ⌊log2(size)⌋ − 2 levels

The implementation lives in :mod:`inkmotion.image_losses.multiscale_mse`; this module is
the plugin's registration only and imports no torch, so listing plugins stays fast.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import ImageLoss


class MultiscaleMse:
    """The multi-scale MSE against a fixed target, its pyramid computed once."""

    name = "mse"
    description = (
        "Multi-scale MSE (paper eq. mse): Gaussian blur σ=1 and ½ downscale per level, "
        "⌊log2(size)⌋−2 levels, summed."
    )

    def prepare(
        self, target: Any, levels: int | None = None
    ) -> Callable[[torch.Tensor], torch.Tensor]:
        """``loss(rendered (H, W)) -> scalar`` against the reference image (H, W).

        ``target`` is a :class:`~inkmotion.plugin_host.protocols.Reference` (its image is
        used; a caption alone cannot be compared pixel by pixel) or the image tensor itself.
        """
        image = getattr(target, "image", target)
        if image is None:
            from inkmotion.errors import SpecError

            raise SpecError("The mse image loss needs a target image, and this job has only "
                            "a caption; use a caption loss such as clip-text.")
        from inkmotion.image_losses.multiscale_mse import prepare_multiscale_mse

        return prepare_multiscale_mse(image, levels)


@hookimpl
def inkmotion_image_losses() -> list[ImageLoss]:
    return [MultiscaleMse()]
