"""The 'export' robot backend: a program for a real controller, at the controller's rate.

Writes into ``FOLDER/export/``:

- ``joints_<rate>Hz.csv``: ``t,q1..q7`` (s, rad);
- ``cartesian_<rate>Hz.csv``: ``t,x,y,z,pen_down`` (pen tip, m, robot base frame);
- ``trajectory.json``: the same arrays with a header.

Both CSVs start with ``#`` comment lines holding the header as JSON, so a controller can
check what it is about to run: the setup (TOML text as used), the limits (speed,
acceleration, joint margins, Panda joint limits), the calibration (plane origin, rotation,
residual, mm per px) and the timing (time scale, duration). Resampling from the control
rate: a C² cubic spline of q(t) and of the pen tip (exact at the control samples), pen_down
by nearest sample.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from inkmotion.robot.types import RobotProgram


def program_header(program: RobotProgram, rate: float) -> dict[str, Any]:
    """The header of an export: setup, limits, calibration and timing of ``program``."""
    from inkmotion.robot import limits

    setup = program.setup
    plane = setup.plane
    return {
        "format": "inkmotion robot export 1",
        "rate_hz": rate,
        "duration_s": float(program.cartesian.t[-1]),
        "time_scale": float(program.cartesian.time_scale),
        "frame": "robot base (panda_link0), metres, radians",
        "setup_toml": setup.source,
        "limits": {
            "v_max_m_s": setup.v_max, "a_max_m_s2": setup.a_max,
            "joint_margin_rad": setup.joint_margin, "limit_fraction": setup.limit_fraction,
            "joint_velocity_rad_s": limits.VELOCITY_LIMITS.tolist(),
            "joint_acceleration_rad_s2": limits.ACCELERATION_LIMITS.tolist(),
            "joint_jerk_rad_s3": limits.JERK_LIMITS.tolist(),
        },
        "calibration": {
            "plane_origin_m": np.asarray(plane.origin).tolist(),
            "plane_rotation": np.asarray(plane.rotation).tolist(),
            "plane_residual_m": float(plane.residual),
            "m_per_px": float(program.mapping.scale),
            "canvas_px": list(program.canvas),
        },
        "pen_length_m": setup.pen_length,
    }


def resample(t: np.ndarray, values: np.ndarray, t_new: np.ndarray) -> np.ndarray:
    """``values`` (N, k) sampled at ``t`` (N,) → (M, k) at ``t_new`` by a cubic spline."""
    from scipy.interpolate import CubicSpline

    if len(t) < 2:
        return np.repeat(values[:1], len(t_new), axis=0)
    return CubicSpline(t, values, axis=0, bc_type="clamped")(t_new)


def export_program(program: RobotProgram, folder: Path, rate: float = 1000.0) -> dict:
    """Write the export files (see the module docstring); return their figures."""
    out = folder / "export"
    out.mkdir(parents=True, exist_ok=True)
    cart, joints = program.cartesian, program.joints
    duration = float(cart.t[-1])
    n = int(np.floor(duration * rate + 1e-9)) + 1
    t_new = np.arange(n) / rate
    q = resample(joints.t, joints.q, t_new)
    tip = resample(cart.t, cart.position, t_new)
    nearest = np.clip(np.rint(t_new * cart.rate).astype(int), 0, len(cart.t) - 1)
    pen = cart.pen_down[nearest]
    header = program_header(program, rate)
    comment = "".join(f"# {line}\n" for line in json.dumps(header, indent=1).splitlines())
    tag = f"{rate:g}Hz"
    _write_csv(out / f"joints_{tag}.csv", comment, ["t"] + [f"q{i}" for i in range(1, 8)],
               np.column_stack((t_new, q)))
    _write_csv(out / f"cartesian_{tag}.csv", comment, ["t", "x", "y", "z", "pen_down"],
               np.column_stack((t_new, tip, pen.astype(float))))
    doc = {"header": header, "t": t_new.tolist(), "q": q.tolist(), "tip": tip.tolist(),
           "pen_down": pen.astype(bool).tolist()}
    (out / "trajectory.json").write_text(json.dumps(doc))
    return {"export_rate_hz": rate, "export_samples": n,
            "export_files": sorted(p.name for p in out.iterdir())}


def _write_csv(path: Path, comment: str, columns: list[str], rows: np.ndarray) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(comment)
        f.write(",".join(columns) + "\n")
        np.savetxt(f, rows, delimiter=",", fmt="%.9g")
