"""Read a recording back with rerun's own Python API (tests, ``inkmotion jobs show``)."""

from __future__ import annotations

from pathlib import Path


def _entity(name: str) -> str:
    return name if name.startswith("/") else "/" + name


def read_steps(path: str | Path, entity: str = "t_end") -> list[int]:
    """The ``step`` values at which ``entity`` was logged in the .rrd at ``path``, sorted
    (one per logged row; a complete fit has 1..steps once each for ``t_end``)."""
    from rerun.chunk import RrdReader

    want = _entity(entity)
    steps: list[int] = []
    for chunk in RrdReader(str(path)).stream():
        if chunk.entity_path != want or chunk.is_static or "step" not in chunk.timeline_names:
            continue
        batch = chunk.to_record_batch()
        steps.extend(int(v) for v in batch.column("step").to_pylist() if v is not None)
    return sorted(steps)


def read_step_count(path: str | Path, entity: str = "t_end") -> int:
    """Number of distinct steps logged for ``entity`` (default ``t_end``, logged every step)."""
    return len(set(read_steps(path, entity)))


def entity_paths(path: str | Path) -> set[str]:
    """Every entity path that holds data in the recording."""
    from rerun.chunk import RrdReader

    return {c.entity_path for c in RrdReader(str(path)).stream()}
