"""The job options shared by ``inkmotion run fit`` and ``inkmotion submit fit``.

Both commands declare their options with the ``Annotated`` aliases below and build the
spec with :func:`spec_from_cli`, so a job submitted to the workers is exactly the job
``run`` would execute. Options left unset keep the value of ``--config job.json`` when one
is given, else the defaults of :class:`~inkmotion.jobs.spec.FitParams`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from inkmotion.jobs.spec import JobSpec

# typer needs typing.Optional in annotations on Python 3.10
InputArg = Annotated[Optional[str], typer.Argument(  # noqa: UP045
    help="GML/JSON/SVG/image file, or text:WORD.", show_default=False)]
ConfigOpt = Annotated[Optional[Path], typer.Option(  # noqa: UP045
    "--config", help="A job.json (or spec JSON) to start from; flags override it.")]
StepsOpt = Annotated[Optional[int], typer.Option(  # noqa: UP045
    "--steps", help="Adam steps \\[default: 300].", show_default=False)]
SizeOpt = Annotated[Optional[int], typer.Option(  # noqa: UP045
    "--size", help="Canvas longer side, px \\[default: 350].", show_default=False)]
SeedOpt = Annotated[Optional[int], typer.Option(  # noqa: UP045
    "--seed", help="Random seed \\[default: 0].", show_default=False)]
LambdaOpt = Annotated[Optional[float], typer.Option(  # noqa: UP045
    "--lambda", "--lambda-smooth",
    help="Weight λ of the smoothing (minimum-time) cost \\[default: 20].", show_default=False)]
WImageOpt = Annotated[Optional[float], typer.Option(  # noqa: UP045
    "--w-image", help="Weight of the image loss \\[default: 200].", show_default=False)]
WidthOpt = Annotated[Optional[float], typer.Option(  # noqa: UP045
    "--width", help="Stroke width, px \\[default: 3].", show_default=False)]
DceOpt = Annotated[Optional[float], typer.Option(  # noqa: UP045
    "--dce-threshold", help="DCE relevance threshold, px \\[default: 1].", show_default=False)]
InitialiserOpt = Annotated[Optional[str], typer.Option(  # noqa: UP045
    "--initialiser", help="Initialiser plugin \\[default: dce].", show_default=False)]
RendererOpt = Annotated[Optional[str], typer.Option(  # noqa: UP045
    "--renderer", help="Renderer plugin \\[default: raster].", show_default=False)]
LossOpt = Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
    "--loss", help="Image-loss plugin, repeatable \\[default: mse].", show_default=False)]
DeviceOpt = Annotated[Optional[str], typer.Option(  # noqa: UP045
    "--device", help="cpu, cuda or auto \\[default: cpu].", show_default=False)]
RecordEveryOpt = Annotated[Optional[int], typer.Option(  # noqa: UP045
    "--record-every",
    help="Rendered images into recording.rrd every k steps, 0 for none \\[default: 10].",
    show_default=False)]


def spec_from_cli(
    kind: str = "fit",
    input: str | None = None,
    *,
    config: Path | None = None,
    steps: int | None = None,
    size: int | None = None,
    seed: int | None = None,
    lambda_smooth: float | None = None,
    w_image: float | None = None,
    width: float | None = None,
    dce_threshold: float | None = None,
    initialiser: str | None = None,
    renderer: str | None = None,
    loss: list[str] | None = None,
    device: str | None = None,
    record_every: int | None = None,
    validate: bool = True,
) -> JobSpec:
    """The :class:`JobSpec` the command-line options describe.

    Starts from ``config`` (a job.json) when given, else from the defaults; every option
    that is not ``None`` overrides. ``validate`` runs :meth:`JobSpec.validate`, which
    raises a :class:`~inkmotion.errors.SpecError` / ``PluginError`` with one sentence.
    """
    spec = JobSpec.load(config) if config is not None else JobSpec(kind=kind)
    if config is None or kind != "fit":
        spec.kind = kind
    if input is not None:
        spec.input = input
    top: dict[str, Any] = {"seed": seed, "initialiser": initialiser, "renderer": renderer,
                           "device": device, "losses": list(loss) if loss else None}
    for name, value in top.items():
        if value is not None:
            setattr(spec, name, value)
    params: dict[str, Any] = {"steps": steps, "size": size, "lambda_smooth": lambda_smooth,
                              "w_image": w_image, "width": width,
                              "dce_threshold": dce_threshold, "record_every": record_every}
    for name, value in params.items():
        if value is not None:
            setattr(spec.params, name, value)
    return spec.validate() if validate else spec
