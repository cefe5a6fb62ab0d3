"""Plotter machine profiles: the limits the firmware enforces and how it lifts the pen.

Built-in profiles (``MACHINES``): ``grbl`` (a servo pen on the spindle output, ``M3 S…`` /
``M5``, G4 P in seconds), ``marlin`` and ``klipper`` (a pen on Z, G4 P in milliseconds);
``custom`` reads the same fields from a TOML file (``[machine]`` table). Limits are those
of the firmware's planner: ``max_feed`` ($110/$111, mm/s), ``max_accel`` ($120/$121,
mm/s²), ``junction_deviation`` ($11, mm; Klipper's square_corner_velocity v_sc converts as
δ = v_sc²·(√2 − 1)/a) and ``planner_blocks`` (its look-ahead buffer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

from inkmotion.errors import InputError


@dataclass(frozen=True)
class Machine:
    """A plotter's limits and pen commands (see the module docstring)."""

    name: str
    max_feed: float  # mm/s, the fastest feed (and the rapid rate)
    max_accel: float  # mm/s²
    junction_deviation: float  # mm
    pen_up: str  # G-code line(s) that lift the pen
    pen_down: str  # G-code line(s) that lower it
    dwell: str  # a dwell, formatted with seconds= and ms=
    dwell_down_s: float = 0.15  # wait after the pen is lowered
    dwell_up_s: float = 0.10  # wait after it is lifted
    pen_move_s: float = 0.0  # how long a pen command itself takes (a Z move), s
    planner_blocks: int = 16  # look-ahead buffer of the firmware's planner
    header: str = "G21\nG90"  # mm, absolute
    footer: str = ""

    def dwell_line(self, seconds: float) -> str:
        """The dwell command for ``seconds``."""
        return self.dwell.format(seconds=seconds, ms=1000.0 * seconds)


def _klipper_deviation(square_corner_velocity: float, accel: float) -> float:
    return square_corner_velocity**2 * (math.sqrt(2.0) - 1.0) / accel


MACHINES: dict[str, Machine] = {
    "grbl": Machine("grbl", max_feed=100.0, max_accel=1000.0, junction_deviation=0.01,
                    pen_up="M5", pen_down="M3 S1000", dwell="G4 P{seconds:.3f}",
                    planner_blocks=15),
    "marlin": Machine("marlin", max_feed=100.0, max_accel=1000.0, junction_deviation=0.013,
                      pen_up="G0 Z3", pen_down="G1 Z0 F1200", dwell="G4 P{ms:.0f}",
                      pen_move_s=0.15),
    "klipper": Machine("klipper", max_feed=100.0, max_accel=1000.0,
                       junction_deviation=_klipper_deviation(5.0, 1000.0),
                       pen_up="G0 Z3", pen_down="G1 Z0 F1200", dwell="G4 P{ms:.0f}",
                       pen_move_s=0.15, planner_blocks=64),
}
_REQUIRED = ("name", "max_feed", "max_accel", "junction_deviation", "pen_up", "pen_down",
             "dwell")


def load_machine(name: str, file: str | Path | None = None) -> Machine:
    """The profile ``name`` (``grbl``, ``marlin``, ``klipper``) or, for ``custom``, the
    ``[machine]`` table of the TOML ``file``; one sentence naming what is wrong otherwise."""
    if name != "custom":
        if file:
            raise InputError(f"--machine-file {file} applies to --machine custom only (this "
                             f"plot's machine is {name}); add --machine custom to plot with "
                             "that file, or leave --machine-file out.")
        if name not in MACHINES:
            raise InputError(f"machine {name!r} is not one of {', '.join(MACHINES)} or custom;"
                             " pick one, or pass --machine custom --machine-file FILE.toml.")
        return MACHINES[name]
    if not file:
        raise InputError("--machine custom needs --machine-file FILE.toml with a [machine] "
                         "table (see docs: the plotter machine file).")
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        table = tomllib.loads(Path(file).read_text(encoding="utf-8")).get("machine")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"machine file {file}: {exc}; fix the file or pass another.") from exc
    if not isinstance(table, dict):
        raise InputError(f"machine file {file} has no [machine] table; add one with "
                         f"{', '.join(_REQUIRED)}.")
    known = {f.name for f in fields(Machine)}
    missing = [k for k in _REQUIRED if k not in table]
    unknown = sorted(set(table) - known)
    if missing or unknown:
        raise InputError(f"machine file {file}: " + "; ".join(
            ([f"missing {', '.join(missing)}"] if missing else [])
            + ([f"unknown {', '.join(unknown)}"] if unknown else [])) + ".")
    machine = replace(MACHINES["grbl"], **table)
    for key in ("max_feed", "max_accel", "junction_deviation"):
        value = getattr(machine, key)
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise InputError(f"machine file {file}: {key} = {value!r} must be a positive "
                             "number.")
    try:
        machine.dwell_line(0.1)
    except (KeyError, ValueError, IndexError) as exc:
        raise InputError(f"machine file {file}: dwell = {machine.dwell!r} is not a format "
                         "with {seconds} or {ms}; e.g. \"G4 P{seconds:.3f}\".") from exc
    return machine
