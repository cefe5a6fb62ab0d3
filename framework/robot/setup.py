"""The robot setup: a TOML file (the shipped ``default_setup.toml`` documents every key) read
into a :class:`RobotSetup`, with the drawing plane calibrated from its four taught corners.

Every key is required and checked; an unknown, missing, mistyped or non-finite one is an
``InputError`` naming the file and the key. ``setup_to_toml`` writes a setup back (the text
the job keeps as setup.toml), and ``load_setup(path, overrides)`` reads one with some
values replaced (e.g. ``{"v_max": 0.25}`` from the command line).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from inkmotion.errors import InputError
from inkmotion.robot.calibration import DrawingPlane
from inkmotion.robot.limits import (
    CARTESIAN_ACCELERATION_LIMIT,
    CARTESIAN_SPEED_LIMIT,
    FR3,
    PANDA,
    first_outside,
)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

DEFAULT_SETUP = Path(__file__).with_name("default_setup.toml")
#: the paper may exceed the taught rectangle by this much (m) before the setup is refused
PAPER_TOLERANCE = 0.01


@dataclass
class RobotSetup:
    """A calibrated drawing bench (SI units, robot base frame); see default_setup.toml."""

    plane_points: np.ndarray  # (4, 3) m, taught corners in order around the rectangle
    paper: tuple[float, float]  # (width, height) m; width along the plane's x
    margin: float  # m kept free on every side
    pen_length: float  # m, tip from the flange (panda_link8) along its z axis
    pen_up: float  # m, tip height above the paper during transfers
    contact_offset: float  # m, pen-down distance from the paper at radius 0 (< 0 presses)
    press_per_px: float  # m per px of stroke radius
    v_max: float  # m/s
    a_max: float  # m/s²
    joint_margin: float  # rad from each joint position limit
    limit_fraction: float  # of the Panda's joint velocity/acceleration/jerk limits
    home: np.ndarray  # (7,) rad
    control_rate: float  # Hz
    plane: DrawingPlane  # calibrated from plane_points
    source: str  # the TOML text as used
    plane_tolerance: float = 0.002  # m, RMS residual allowed for the plane points

    def pen_distance(self, radius: np.ndarray | float) -> np.ndarray:
        """Pen-down distance (m) of the tip from the paper for stroke radius ``radius`` px:
        d(r) = contact_offset − press_per_px · r (the paper's linear radius → distance map)."""
        return self.contact_offset - self.press_per_px * np.asarray(radius, dtype=float)


@dataclass(frozen=True)
class _Key:
    section: str
    name: str
    shape: tuple[int, ...]  # () for a number
    check: str  # "positive" | "non-negative" | "finite" | "fraction"
    doc: str  # one line, written above the key by setup_to_toml
    #: (lowest, highest) a bench can use, where the check alone allows nonsense
    bounds: tuple[float, float] | None = None


#: m: the deepest press and the largest gap of the pen-down tip (contact_offset): under joint
#: impedance a press pushes the tip sideways too (1.3 mm drew 0.75 mm RMS off the plan), and
#: 20 mm drew 13 mm off it with 47 N on the board; a gap over 5 mm never touches the paper
CONTACT_OFFSET_RANGE = (-0.005, 0.005)


_KEYS = (
    _Key("plane", "points", (4, 3), "finite",
         "m: four taught corners of the drawing rectangle, in order around it"),
    _Key("plane", "tolerance", (), "positive", "m: largest RMS distance of the corners to "
         "their plane"),
    _Key("paper", "width", (), "positive", "m: paper width, along points[0] -> points[1]"),
    _Key("paper", "height", (), "positive", "m: paper height, towards points[3]"),
    _Key("paper", "margin", (), "non-negative", "m: kept free on every side"),
    _Key("pen", "length", (), "positive", "m: pen tip from the flange along its z axis"),
    _Key("pen", "up", (), "positive", "m: pen-up height above the paper"),
    _Key("pen", "contact_offset", (), "finite", "m: pen-down distance at radius 0 "
         "(negative presses in)", CONTACT_OFFSET_RANGE),
    _Key("pen", "press_per_px", (), "non-negative", "m per px of stroke radius: distance = "
         "contact_offset - press_per_px * r"),
    _Key("limits", "v_max", (), "positive", "m/s: largest pen-tip speed",
         (0.0, CARTESIAN_SPEED_LIMIT)),
    _Key("limits", "a_max", (), "positive", "m/s^2: largest pen-tip acceleration",
         (0.0, CARTESIAN_ACCELERATION_LIMIT)),
    _Key("limits", "joint_margin", (), "non-negative", "rad: kept from each joint limit"),
    _Key("limits", "limit_fraction", (), "fraction", "of the Panda's joint velocity, "
         "acceleration and jerk limits"),
    _Key("robot", "home", (7,), "finite", "rad: home configuration of the seven arm joints"),
    _Key("robot", "control_rate", (), "positive", "Hz: control rate of the samples"),
)
_BY_NAME = {f"{k.section}.{k.name}": k for k in _KEYS}
#: RobotSetup field -> the key(s) holding it
_FIELDS = {
    "plane_points": ("plane.points",), "plane_tolerance": ("plane.tolerance",),
    "paper": ("paper.width", "paper.height"), "margin": ("paper.margin",),
    "pen_length": ("pen.length",), "pen_up": ("pen.up",),
    "contact_offset": ("pen.contact_offset",), "press_per_px": ("pen.press_per_px",),
    "v_max": ("limits.v_max",), "a_max": ("limits.a_max",),
    "joint_margin": ("limits.joint_margin",), "limit_fraction": ("limits.limit_fraction",),
    "home": ("robot.home",), "control_rate": ("robot.control_rate",),
}
_REQUIREMENT = {"positive": "> 0", "non-negative": "≥ 0", "finite": "finite",
                "fraction": "in (0, 1]"}


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _all_numbers(x: Any) -> bool:
    """True if ``x`` is a number or a (nested) list of numbers only."""
    return all(_all_numbers(y) for y in x) if isinstance(x, (list, tuple)) else _is_number(x)


def _checked(key: _Key, value: Any, source: str) -> float | np.ndarray:
    """``value`` as a float or an array of ``key.shape``, or an InputError naming the key."""
    where = f"{source}: [{key.section}] {key.name}"
    if key.shape:
        what = "an array of " + " × ".join(str(n) for n in key.shape) + " numbers"
    else:
        what = f"a number {_REQUIREMENT[key.check]}"

    def refuse() -> InputError:
        return InputError(f"{where} must be {what}, got {value!r}; correct it (see "
                          f"{DEFAULT_SETUP.name} for every key).")

    if not key.shape:
        if not _is_number(value) or not math.isfinite(value):
            raise refuse()
        x = float(value)
        ok = {"positive": x > 0, "non-negative": x >= 0, "finite": True,
              "fraction": 0 < x <= 1}[key.check]
        if not ok:
            raise refuse()
        if key.bounds is not None and not key.bounds[0] <= x <= key.bounds[1]:
            low, high = key.bounds
            raise InputError(f"{where} = {x:g} is outside {low:g} to {high:g}, what the "
                             f"Panda and a pen can use; correct it (see {DEFAULT_SETUP.name} "
                             "for every key).")
        return x
    if not isinstance(value, (list, tuple)) or not _all_numbers(value):
        raise refuse()
    try:
        array = np.asarray(value, dtype=float)
    except ValueError:  # ragged
        raise refuse() from None
    if array.shape != key.shape or not np.all(np.isfinite(array)):
        raise refuse()
    return array


def _flatten(doc: Mapping[str, Any], source: str) -> dict[str, Any]:
    """{"section.key": value} of a parsed TOML document, refusing unknown sections/keys."""
    out: dict[str, Any] = {}
    for section, table in doc.items():
        if not isinstance(table, dict):
            raise InputError(f"{source}: {section} is not a known section (known: "
                             f"{', '.join(sorted({k.section for k in _KEYS}))}); "
                             "remove it or correct its name.")
        for name, value in table.items():
            dotted = f"{section}.{name}"
            if dotted not in _BY_NAME:
                known = ", ".join(k.name for k in _KEYS if k.section == section)
                raise InputError(f"{source}: unknown key [{section}] {name} (known in "
                                 f"[{section}]: {known or 'none'}); remove it or correct its "
                                 "name.")
            out[dotted] = value
    return out


def _apply_overrides(values: dict[str, Any], overrides: Mapping[str, Any]) -> None:
    """Replace entries of ``values`` by ``overrides``, keyed by RobotSetup field name
    (``paper`` takes a (width, height) pair) or by "section.key"."""
    for name, value in overrides.items():
        if isinstance(value, (np.ndarray, np.generic)):
            value = value.tolist()
        if name in _FIELDS:
            keys = _FIELDS[name]
            if len(keys) == 2:
                if not isinstance(value, (list, tuple)) or len(value) != 2:
                    raise InputError(f"the setup override {name} must be a (width, height) "
                                     f"pair in metres, got {value!r}; pass two numbers.")
                values.update(zip(keys, value, strict=True))
            else:
                values[keys[0]] = value
        elif name in _BY_NAME:
            values[name] = value
        else:
            raise InputError(f"unknown setup override {name!r} (known: "
                             f"{', '.join(_FIELDS)}); correct its name.")


def parse_setup(text: str, source: str = "setup.toml",
                overrides: Mapping[str, Any] | None = None) -> RobotSetup:
    """A :class:`RobotSetup` from TOML ``text`` (``source`` names it in error messages),
    with ``overrides`` applied (see :func:`load_setup`)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{source}: is not valid TOML ({exc}); fix its syntax.") from exc
    values = _flatten(doc, source)
    if overrides:
        _apply_overrides(values, overrides)
    for dotted, key in _BY_NAME.items():
        if dotted not in values:
            raise InputError(f"{source}: key [{key.section}] {key.name} is missing; add it "
                             f"(see {DEFAULT_SETUP.name} for every key).")
    v = {dotted: _checked(key, values[dotted], "the setup overrides"
                          if _overridden(dotted, overrides or {}) else source)
         for dotted, key in _BY_NAME.items()}
    setup = _build(v, source)
    if overrides:
        given = ", ".join(f"{k} = {_plain(value)}" for k, value in overrides.items())
        header = f"# {source} with overrides: {given}\n"
        return dataclasses.replace(setup, source=header + setup_to_toml(setup))
    return dataclasses.replace(setup, source=text)


def _plain(value: Any) -> str:
    """``value`` on one line (a comment of the TOML text)."""
    if isinstance(value, (np.ndarray, np.generic)):
        value = value.tolist()
    return repr(value).replace("\n", " ")


def _overridden(dotted: str, overrides: Mapping[str, Any]) -> bool:
    return dotted in overrides or any(dotted in _FIELDS.get(n, ()) for n in overrides)


def _build(v: dict[str, Any], source: str) -> RobotSetup:
    """Cross-key checks, the plane's calibration and the dataclass."""
    width, height, margin = v["paper.width"], v["paper.height"], v["paper.margin"]
    if 2 * margin >= min(width, height):
        raise InputError(f"{source}: [paper] margin {margin} m leaves no paper of "
                         f"{width} × {height} m; make it smaller than {min(width, height) / 2} m.")
    if v["pen.contact_offset"] >= v["pen.up"]:
        raise InputError(f"{source}: [pen] up {v['pen.up']} m must be above the contact "
                         f"distance [pen] contact_offset {v['pen.contact_offset']} m; raise it.")
    home, margin_rad = v["robot.home"], v["limits.joint_margin"]
    lower = np.minimum(PANDA.lower, FR3.lower)  # the arm is chosen later: either may draw
    upper = np.maximum(PANDA.upper, FR3.upper)
    j = first_outside(home, lower + margin_rad, upper - margin_rad)
    if j is not None:
        raise InputError(f"{source}: [robot] home joint {j + 1} = {home[j]:g} rad is outside "
                         f"the Franka arms' range {lower[j]:.4f} to {upper[j]:.4f} rad less "
                         f"joint_margin {margin_rad:g}; give a home inside it (the default's "
                         "is [0, -0.785, 0, -2.356, 0, 1.571, 0.785]).")
    plane = DrawingPlane.from_points(v["plane.points"], f"{source}: [plane] points",
                                     tolerance=v["plane.tolerance"])
    for name, length, taught in (("width", width, plane.size[0]),
                                 ("height", height, plane.size[1])):
        if length > taught + PAPER_TOLERANCE:
            raise InputError(f"{source}: [paper] {name} {length} m exceeds the taught "
                             f"rectangle's {taught:.3f} m; teach the paper's corners or make "
                             "the paper smaller.")
    return RobotSetup(
        plane_points=v["plane.points"], paper=(width, height), margin=margin,
        pen_length=v["pen.length"], pen_up=v["pen.up"],
        contact_offset=v["pen.contact_offset"], press_per_px=v["pen.press_per_px"],
        v_max=v["limits.v_max"], a_max=v["limits.a_max"],
        joint_margin=v["limits.joint_margin"], limit_fraction=v["limits.limit_fraction"],
        home=v["robot.home"], control_rate=v["robot.control_rate"], plane=plane, source="",
        plane_tolerance=v["plane.tolerance"])


def load_setup(path: str | Path | None = None,
               overrides: Mapping[str, Any] | None = None) -> RobotSetup:
    """Read a setup TOML file (None: the shipped default_setup.toml) with ``overrides``
    replacing some values, keyed by :class:`RobotSetup` field name (``{"v_max": 0.25}``;
    ``paper`` takes a (width, height) pair) or by "section.key". ``source`` keeps the file's
    text, or, with overrides, the setup as used written by :func:`setup_to_toml`."""
    path = Path(path) if path is not None else DEFAULT_SETUP
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the robot setup ({exc.__class__.__name__}); "
                         "check the path or omit it to use the default setup.") from exc
    return parse_setup(text, str(path), overrides)


def _toml_value(value: float | np.ndarray) -> str:
    if isinstance(value, np.ndarray):
        if value.ndim == 1:
            return "[" + ", ".join(repr(float(x)) for x in value) + "]"
        rows = ",\n".join("    " + _toml_value(row) for row in value)
        return "[\n" + rows + ",\n]"
    return repr(float(value))


def setup_to_toml(setup: RobotSetup) -> str:
    """The TOML text of ``setup`` (every key with a one-line comment); parsing it gives the
    same setup back."""
    values = {
        "plane.points": setup.plane_points, "plane.tolerance": setup.plane_tolerance,
        "paper.width": setup.paper[0], "paper.height": setup.paper[1],
        "paper.margin": setup.margin, "pen.length": setup.pen_length, "pen.up": setup.pen_up,
        "pen.contact_offset": setup.contact_offset, "pen.press_per_px": setup.press_per_px,
        "limits.v_max": setup.v_max, "limits.a_max": setup.a_max,
        "limits.joint_margin": setup.joint_margin,
        "limits.limit_fraction": setup.limit_fraction,
        "robot.home": np.asarray(setup.home, dtype=float),
        "robot.control_rate": setup.control_rate,
    }
    lines = ["# inkmotion robot setup (SI units, robot base frame)"]
    section = None
    for key in _KEYS:
        if key.section != section:
            section = key.section
            lines += ["", f"[{section}]"]
        value = values[f"{key.section}.{key.name}"]
        value = np.asarray(value, dtype=float) if key.shape else value
        lines += [f"# {key.doc}", f"{key.name} = {_toml_value(value)}"]
    return "\n".join(lines) + "\n"
