"""Reading and writing the project's JSON files (job.json, plan.json, report.json): one-sentence
errors for a file that is not JSON, and no NaN in a file written."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from inkmotion.errors import InkmotionError


def read_json(path: str | Path, error: type[InkmotionError], what: str = "file") -> Any:
    """The parsed JSON of ``path``; a missing or malformed file raises ``error`` naming it."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError as exc:
        raise error(f"{path}: no such {what}.") from exc
    except IsADirectoryError as exc:
        raise error(f"{path}: is a folder, not a {what}; give the file in it.") from exc
    except OSError as exc:
        raise error(f"{path}: the {what} cannot be read ({exc.strerror}).") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: is not valid JSON ({exc}); give the {what} as inkmotion "
                    "wrote it (a truncated copy or an edit may have broken it).") from exc
    except RecursionError as exc:
        raise error(f"{path}: its JSON is nested too deeply to be a {what}; give the "
                    f"{what} inkmotion wrote.") from exc


def json_ready(value: Any, default: Callable[[Any], Any] | None = None) -> Any:
    """``value`` as plain JSON data: NumPy/torch scalars and arrays via ``item``/``tolist``,
    and NaN or infinities as None (JSON has no NaN: strict readers and PostgreSQL's
    ``json`` refuse it; a figure that does not apply, such as a T_end ratio over no path of
    two moves, is null). Anything else becomes ``default(value)`` (e.g. ``str``); without
    a ``default`` it raises TypeError."""
    if isinstance(value, float):
        return float(value) if math.isfinite(value) else None  # np.float64 -> float
    if isinstance(value, dict):
        return {str(k): json_ready(v, default) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v, default) for v in value]
    if value is None or isinstance(value, str | int):
        return value
    for method in ("item", "tolist"):  # numpy / torch scalars, arrays, tensors
        if callable(getattr(value, method, None)):
            try:
                return json_ready(getattr(value, method)(), default)
            except (TypeError, ValueError, RuntimeError):
                continue
    if default is not None:
        return json_ready(default(value))
    raise TypeError(f"{value!r} ({type(value).__name__}) is not JSON data.")


def dumps(obj: Any, default: Callable[[Any], Any] | None = None, **kwargs: Any) -> str:
    """``json.dumps`` of :func:`json_ready` ``obj``: valid JSON whatever floats it holds
    (``default`` as for :func:`json_ready`; ``kwargs`` go to ``json.dumps``)."""
    return json.dumps(json_ready(obj, default), allow_nan=False, **kwargs)
