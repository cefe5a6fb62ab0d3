"""A finished job's result as the studio's page draws it: the motion, its speed, figures.

For a fit (or any job that wrote plan.json) :func:`motion_payload` gives each path sampled
uniformly in time (20 samples per sub-movement, float64 on the CPU,
:func:`inkmotion.outputs.sampling.sample`) with its speed and the speed of each lognormal
(:func:`inkmotion.sigma_lognormal.speed.lognormal_speeds`, the bells of the speed plot),
the input strokes, and the report's figures. The page animates the pen on that timeline:
path k starts :data:`PEN_LIFT_S` after path k − 1 ends (a pen lift is not part of the ΣΛ
model; the animation shows it as a pause and a dashed move).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

#: the pause the animation gives a pen lift between two paths, s
PEN_LIFT_S = 0.3
#: samples per sub-movement of the animated motion
PER_MOVE = 20
#: report figures the page names (in this order), when the job reported them
FIGURES = ("moves", "paths", "chamfer_mean_px", "chamfer_max_px", "t_end_ratio", "quality",
           "delta_t_at_clamp", "fit_s", "wall_s", "estimated_s", "drawn_mm", "travel_mm",
           "peak_feed", "strokes")


def motion_payload(artifacts: Path) -> dict[str, Any]:
    """The page's data for the job whose artifacts are in ``artifacts`` (module
    docstring); ``{"figures": ..., "files": [...]}`` only when it wrote no plan.json."""
    report = _json(artifacts / "report.json") or {}
    payload: dict[str, Any] = {
        "figures": {k: report[k] for k in FIGURES if k in report},
        "warnings": [str(w) for w in report.get("warnings", [])],
        "kind": report.get("kind"),
        "files": sorted(p.name for p in artifacts.iterdir() if p.is_file()),
    }
    if "extraction" in report:
        payload["extraction"] = {k: report["extraction"].get(k)
                                 for k in ("strokes", "junctions", "pen_lifts")}
    plan_file = artifacts / "plan.json"
    if not plan_file.is_file():
        return payload
    import numpy as np
    import torch

    from inkmotion.outputs.sampling import on_cpu, sample
    from inkmotion.sigma_lognormal import Drawing
    from inkmotion.sigma_lognormal.speed import lognormal_speeds

    drawing = Drawing.load(plan_file)
    paths, start = [], 0.0
    for plan in drawing.plans:
        s = sample(plan, PER_MOVE)
        with torch.no_grad():
            bells = lognormal_speeds(on_cpu(plan, torch.float64), torch.from_numpy(s.t))
        paths.append({"start": round(start, 4), "t": _round(s.t, 4),
                      "xy": _round(s.positions[:, :2], 2), "speed": _round(s.speed, 1),
                      "bells": _round(bells.numpy(), 1),
                      "targets": _round(plan.points[:, :2].numpy(), 2),
                      "width": float(plan.width),
                      "radius": (_round(s.positions[:, 2], 2) if plan.dim == 3 else None)})
        start += float(s.t[-1]) + PEN_LIFT_S
    payload.update(canvas=list(drawing.canvas), paths=paths, pen_lift_s=PEN_LIFT_S,
                   duration=round(start - PEN_LIFT_S, 4),
                   peak_speed=float(max(np.max(p["speed"]) for p in paths)))
    source = _json(artifacts / "input.json")
    if source is not None:
        payload["traces"] = [_round(np.asarray(t)[:, :2], 1) for t in source.get("traces", [])]
    return payload


def warm_up() -> None:
    """Import what :func:`motion_payload` needs (torch: about 2 s), ahead of the first
    result; run in a thread when the studio starts."""
    import inkmotion.outputs.sampling  # noqa: F401
    import inkmotion.sigma_lognormal.speed  # noqa: F401


def _round(a: Any, digits: int) -> list:
    import numpy as np

    return np.round(np.asarray(a, dtype=float), digits).tolist()


def _json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None
