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
import re
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


#: G-code words that change what the plot's coordinates and feeds mean: inches (G20, G70),
#: relative moves (G91; G91.1 only sets arc centres), inverse-time feed (G93). (A work
#: offset, G54–G59 or G92, moves the origin, which a header may do on purpose.)
_MODAL = {20.0: "G20", 70.0: "G70", 91.0: "G91", 93.0: "G93"}
#: a G-code word: its letter and number, spaces allowed between (``G 91``), none needed
#: before the next word (``M5G91``, ``N10G20``)
_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))", re.IGNORECASE)


def gcode_words(gcode: str) -> set[tuple[str, float]]:
    """The words of ``gcode`` (comments left out) as (letter, number): ``G21`` → ("G", 21)."""
    code = re.sub(r"\([^)]*\)|;.*", "", gcode)
    return {(letter.upper(), float(number)) for letter, number in _WORD.findall(code)}


def _mode_changes(gcode: str) -> list[str]:
    """The words of ``gcode`` that change the coordinates' meaning."""
    return sorted({_MODAL[number] for letter, number in gcode_words(gcode)
                   if letter == "G" and number in _MODAL})


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
    for key in ("max_feed", "max_accel", "junction_deviation", "dwell_down_s", "dwell_up_s",
                "pen_move_s", "planner_blocks"):
        value = getattr(machine, key)
        positive = key in ("max_feed", "max_accel", "junction_deviation", "planner_blocks")
        if (isinstance(value, bool) or not isinstance(value, (int, float))
                or not math.isfinite(value) or value < 0 or (positive and value == 0)
                or (key == "planner_blocks" and not isinstance(value, int))):
            kind = ("a whole number ≥ 1" if key == "planner_blocks" else
                    "a positive number" if positive else "a number ≥ 0")
            raise InputError(f"machine file {file}: {key} = {value!r} must be {kind}; "
                             "correct it.")
    for key in ("name", "pen_up", "pen_down", "dwell", "header", "footer"):
        value = getattr(machine, key)
        pen = {"pen_up": "lift", "pen_down": "lower"}.get(key)
        if not isinstance(value, str) or (pen is not None and not value.strip()):
            what = (f"the G-code line(s) that {pen} the pen (a plot without them draws "
                    "every travel move)" if pen is not None else "text")
            raise InputError(f"machine file {file}: {key} = {value!r} must be {what}; "
                             "correct it.")
        modal = _mode_changes(value) if key != "name" else []
        if modal:
            raise InputError(f"machine file {file}: {key} holds {', '.join(modal)}, which "
                             "would make the plot's millimetre, absolute coordinates mean "
                             "something else (inches, or moves relative to the last); take it "
                             "out: inkmotion writes G21 and G90 itself.")
    try:
        machine.dwell_line(0.1)
    except (KeyError, ValueError, IndexError) as exc:
        raise InputError(f"machine file {file}: dwell = {machine.dwell!r} is not a format "
                         "with {seconds} or {ms}; e.g. \"G4 P{seconds:.3f}\".") from exc
    return machine
