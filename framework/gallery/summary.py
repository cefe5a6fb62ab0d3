"""How the gallery words a job: its key parameters, figures, durations and file sizes.

Key parameters are the ones a reader needs to tell two jobs of a kind apart: the plugins
chosen, then every parameter that differs from the kind's default (the declaration in
:mod:`inkmotion.jobs.params` says what the default is). A kind that no longer loads (its
plugin was removed) shows all its scalar parameters instead.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

#: the units and short names of figures the project's job kinds report
FIGURE_NAMES: dict[str, str] = {
    "moves": "m (sub-movements)",
    "chamfer_mean_px": "Chamfer mean, px",
    "chamfer_max_px": "Chamfer max, px",
    "t_end_ratio": "T_end / initial",
    "delta_t_at_clamp": "Δt at clamp",
    "fit_speed_peaks": "speed peaks",
}


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
        return f"{value:.3g}"
    if value is None:
        return "—"
    return str(value)


def figure_name(key: str) -> str:
    return FIGURE_NAMES.get(key, key.replace("_", " "))


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
