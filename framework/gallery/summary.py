"""How the gallery words a job: its key parameters, figures, durations and file sizes.

Key parameters are the ones a reader needs to tell two jobs of a kind apart: the plugins
chosen, then every parameter that differs from the kind's default (the declaration in
:mod:`inkmotion.jobs.params` says what the default is). A kind that no longer loads (its
plugin was removed) shows all its scalar parameters instead.
"""

from __future__ import annotations

import math
import re
from functools import lru_cache
from typing import Any

#: a figure's label and unit, as a card and a page name it; kinds' own keys in
#: :data:`KIND_FIGURES` (the same key can mean another thing in another kind)
FIGURES: dict[str, tuple[str, str]] = {
    # what every job's report holds
    "wall_s": ("run time", "s"),
    "threads": ("CPU threads", ""),
    "device": ("device", ""),
    "kind": ("kind", ""),
    "paths": ("paths", ""),
    "moves": ("sub-movements m", ""),
    # optimisations (fit, tag, abstract)
    "steps": ("Adam steps", ""),
    "fit_s": ("optimiser time", "s"),
    "s_per_step": ("time per step", "s"),
    "initial_t_end": ("T_end before", "s"),
    "final_t_end": ("T_end after", "s"),
    "t_end_ratio": ("T_end after / before", "×"),
    "t_end_ratio_multi": ("T_end after / before, paths of m ≥ 2", "×"),
    "chamfer_mean_px": ("Chamfer mean", "px"),
    "chamfer_max_px": ("Chamfer max", "px"),
    "delta_t_at_clamp": ("Δt at a bound", "%"),
    "fit_speed_peaks": ("speed peaks", ""),
    "speed_peaks": ("speed peaks", ""),
    "quality": ("fit quality", ""),
    "clip_similarity": ("CLIP similarity", ""),
    "clip_similarity_initial": ("CLIP similarity before", ""),
    "clip_similarity_final": ("CLIP similarity after", ""),
    # an arm (simulate, draw)
    "duration_s": ("motion time", "s"),
    "drawing_s": ("pen-down time", "s"),
    "time_scale": ("time scale to the limits", "×"),
    "ik_max_position_error_mm": ("IK position error, max", "mm"),
    "tracking_down_plane_rms_mm": ("tracking RMS, pen down", "mm"),
    "tracking_down_plane_max_mm": ("tracking max, pen down", "mm"),
    "contact_coverage": ("drawn in contact", "%"),
    "real_time_factor": ("simulation speed", "× real time"),
    "flange_rms_mm": ("flange tracking RMS", "mm"),
    "flange_max_mm": ("flange tracking max", "mm"),
    "drawing_started_after_s": ("drawing started after", "s"),
    "limit_min_margin": ("smallest margin to a joint limit", ""),
}
KIND_FIGURES: dict[str, dict[str, tuple[str, str]]] = {
    "plot": {"estimated_s": ("plot time, estimated", "s"),
             "peak_feed": ("peak feed", "mm/s"),
             "travel_mm": ("pen-up travel", "mm"),
             "travel_own_order_mm": ("pen-up travel in the plan's order", "mm"),
             "drawn_mm": ("pen-down length", "mm"),
             "feed_speed_correlation": ("correlation of feed and ΣΛ speed", ""),
             "v_max": ("feed limit", "mm/s"), "a_max": ("acceleration limit", "mm/s²"),
             "margin_mm": ("paper margin", "mm"), "mm_per_px": ("scale", "mm/px"),
             "strokes": ("strokes", ""), "order": ("stroke order", "")},
    "evaluate": {"v_max": ("speed limit", "m/s"), "a_max": ("acceleration limit", "m/s²"),
                 "m_per_px": ("scale", "m/px"), "path": ("paths compared", ""),
                 "plotted_path": ("path plotted", "")},
}
#: an evaluation's ratio figures ``<method>_<figure>_ratio``: their words
METHOD_NAMES = {"minimum-jerk": "minimum jerk", "minimum-jerk-sigma-times":
                "minimum jerk at ΣΛ times", "time-optimal": "time-optimal"}
RATIO_NAMES = {"duration": "duration", "msj": "MSJ", "ldj": "LDJ",
               "msj_equal_duration": "MSJ·T⁶"}
#: the columns of evaluation.csv, as its table's header says them
EVALUATION_COLUMNS = {"row": "", "duration": "duration, s", "inverse_duration": "1 / duration, 1/s",
                      "peak_speed": "peak speed, m/s", "speed_peaks": "speed peaks",
                      "msj": "MSJ, m²/s⁶", "ldj": "LDJ", "msj_equal_duration": "MSJ·T⁶"}
#: unit suffixes of figure keys the tables above do not name
SUFFIX_UNITS = {"_s": "s", "_ms": "ms", "_mm": "mm", "_px": "px", "_deg": "°", "_rad": "rad",
                "_n": "N", "_mb": "MB"}


def flatten(params: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"initialiser": {"name": "dce", "relevance": 2.5}}`` →
    ``{"initialiser": "dce", "initialiser.relevance": 2.5}`` (lists of plugins joined)."""
    flat: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and "name" in value:
            flat[name] = value["name"]
            flat.update(flatten({k: v for k, v in value.items() if k != "name"}, f"{name}."))
        elif isinstance(value, dict):
            flat.update(flatten(value, f"{name}."))
        elif isinstance(value, list) and all(isinstance(v, dict) and "name" in v
                                             for v in value):
            flat[name] = ", ".join(str(v["name"]) for v in value) or "none"
            for v in value:
                flat.update(flatten({k: w for k, w in v.items() if k != "name"},
                                    f"{name}.{v['name']}."))
        else:
            flat[name] = value
    return flat


@lru_cache(maxsize=64)
def _declared(kind: str) -> tuple[dict[str, Any], dict[str, str]] | None:
    """The kind's flattened defaults and its plugin fields with their plugin kinds (None:
    the kind does not load)."""
    try:
        from inkmotion.jobs.kind import job_kind
        from inkmotion.jobs.params import describe, to_dict

        declared = job_kind(kind).Params
        plugins = {i.name: i.plugin_kind for i in describe(declared) if i.plugin_kind}
        return flatten(to_dict(declared())), plugins
    except Exception:  # a kind that does not load: show everything (never fail a build)
        return None


@lru_cache(maxsize=64)
def parameter_helps(kind: str) -> dict[str, str]:
    """Each parameter's declared one-line help (``{}`` when the kind does not load)."""
    try:
        from inkmotion.jobs.kind import job_kind
        from inkmotion.jobs.params import describe

        return {i.name: i.help for i in describe(job_kind(kind).Params)}
    except Exception:  # a kind that does not load: no notes (never fail a build)
        return {}


def parameter_rows(kind: str, params: dict[str, Any]) -> list[tuple[str, str, str]]:
    """(name, value, what a special value means) of every parameter: ``v_max 0`` reads
    "0 — the setup's" (the note from the parameter's help, :func:`value_meaning`)."""
    helps = parameter_helps(kind)
    return [(k, show(v), value_meaning(helps.get(k, ""), v) or "")
            for k, v in flatten(params).items()]


@lru_cache(maxsize=64)
def _option_defaults(plugin_kind: str, name: str) -> dict[str, Any]:
    """A plugin's option defaults, ``{}`` when it declares none or does not load."""
    try:
        from inkmotion.jobs.params import to_dict
        from inkmotion.plugin_host import host

        options = getattr(host().get(plugin_kind, name), "Options", None)
        return to_dict(options()) if options is not None else {}
    except Exception:
        return {}


def key_parameters(kind: str, params: dict[str, Any]) -> list[tuple[str, str]]:
    """(name, value) of the plugins chosen and the parameters off their defaults (the
    kind's, or the chosen plugin's for its options)."""
    flat = flatten(params)
    declared = _declared(kind)
    if declared is None:
        return [(k, show(v)) for k, v in flat.items() if not isinstance(v, (dict, list))]
    default, plugin_fields = declared
    default = dict(default)
    for fname, plugin_kind in plugin_fields.items():
        for name in str(flat.get(fname) or "").split(", "):
            prefix = f"{fname}.{name}." if isinstance(params.get(fname), list) else f"{fname}."
            for option, value in _option_defaults(plugin_kind, name).items():
                default[prefix + option] = value
    missing = object()
    plugins = [k for k in flat if k in plugin_fields and flat[k] is not None]
    changed = [k for k, v in flat.items()
               if k not in plugin_fields and default.get(k, missing) != v]
    return [(k, show(flat[k])) for k in plugins + changed]


def show(value: Any) -> str:
    """A parameter or figure as a person reads it: 3 significant digits, no float noise."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        if value.is_integer() and abs(value) < 1e6:  # 1000, not 1e+03
            return str(int(value))
        return f"{value:.3g}"
    if value is None:
        return "—"
    return str(value)


def figure_label(key: str, kind: str = "") -> tuple[str, str]:
    """(label, unit) of a figure of a job of ``kind``, in words: the tables above, an
    evaluation's ``<method>_<figure>_ratio`` as "minimum jerk / ΣΛ, MSJ", else the key
    with its unit suffix (``_s``, ``_mm``, ...) taken off as the unit."""
    known = KIND_FIGURES.get(kind, {}).get(key) or FIGURES.get(key)
    if known is not None:
        return known
    for method, words in METHOD_NAMES.items():
        for figure, name in RATIO_NAMES.items():
            if key == f"{method}_{figure}_ratio":
                return f"{words} / ΣΛ, {name}", "×"
    for suffix, unit in SUFFIX_UNITS.items():
        if key.endswith(suffix) and len(key) > len(suffix):
            return key[:-len(suffix)].replace("_", " "), unit
    return key.replace("_", " "), ""


def with_unit(value: Any, unit: str) -> str:
    """A value as :func:`show` writes it, followed by its unit (``2.8 px``, ``0.706×``; a
    share in ``%``: 0.25 → ``25 %``)."""
    if unit == "%" and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = 100 * value
    shown = show(value)
    if not unit or shown == "—" or not isinstance(value, (int, float)) or \
            isinstance(value, bool):
        return shown
    return f"{shown}{unit}" if unit.startswith("×") else f"{shown} {unit}"


def figure(key: str, value: Any, kind: str = "") -> tuple[str, str]:
    """(label, value with its unit) of a figure, as a card or a page shows it."""
    label, unit = figure_label(key, kind)
    return label, with_unit(value, unit)


def value_meaning(help_text: str, value: Any) -> str | None:
    """What a parameter's special value means, from its declared help: "(0: the setup's)"
    for 0, "empty: the shipped default" for "", "-1: every path" for -1; None when the
    help says nothing of that value."""
    if isinstance(value, bool):
        return None
    if value == "" or value is None:
        token = "empty"
    elif isinstance(value, (int, float)) and float(value).is_integer():
        token = str(int(value))
    else:
        return None
    found = re.search(rf"(?:^|[(;,]\s*){re.escape(token)}: ([^;]+)", help_text)
    if not found:
        return None
    text = found.group(1).strip().rstrip(".")
    while text.endswith(")") and text.count(")") > text.count("("):  # the "(0: ...)" closing
        text = text[:-1].rstrip(".")
    return text or None


def short_label(label: str) -> str:
    """An input as a card's title: a file path shortened to its last two parts."""
    parts = [p for p in label.replace("\\", "/").split("/") if p]
    if "/" in label and len(parts) > 2 and ":" not in label.split("/")[0][1:]:
        return "…/" + "/".join(parts[-2:])
    return label


def duration(seconds: float | None) -> str:
    """``42.1 s``, ``3 min 05 s``, ``1 h 02 min``; ``—`` when unknown."""
    if seconds is None:
        return "—"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, s = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes} min {s:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def size(n: int) -> str:
    """File size: ``812 B``, ``14.2 kB``, ``3.1 MB``."""
    if n < 1000:
        return f"{n} B"
    value, unit = n / 1000, "kB"
    for bigger in ("MB", "GB"):
        if value < 1000:
            break
        value, unit = value / 1000, bigger
    return f"{value:.1f} {unit}"
