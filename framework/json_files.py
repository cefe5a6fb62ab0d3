"""Reading the project's JSON files (job.json, plan.json) with one-sentence errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from inkmotion.errors import InkmotionError


def read_json(path: str | Path, error: type[InkmotionError], what: str = "file") -> Any:
    """The parsed JSON of ``path``; a missing or malformed file raises ``error`` naming it."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError as exc:
        raise error(f"{path}: no such {what}.") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: is not valid JSON ({exc}).") from exc
