"""Several motor plans packed into flat tensors, so every step is one batched evaluation.

Path p owns points ``points[pt_start[p] : pt_start[p] + m_p + 1]`` and sub-movements
``[mv_start[p], mv_start[p] + m_p)`` of the per-sub-movement tensors. The optimiser keeps
these flat tensors as its leaves; :meth:`PlanBatch.to_plans` turns them back into plans.

The index structure that follows from the sub-movement counts m_p alone (which path a
sub-movement or a sample belongs to, where each block starts, ...) is a
:class:`GridLayout`: built once per fit, so a step neither recomputes it nor reads a size
back from the device (static shapes, no host synchronisation).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import torch

from inkmotion.sigma_lognormal.params import end_times, onsets, sigma_mu
from inkmotion.sigma_lognormal.plan import MotorPlan

#: samples per sub-movement of the fitting grid, n_p = 5·m_p
SAMPLES_PER_MOVE = 5

#: σ, μ and the onsets t0 of every sub-movement, (M,) each (:meth:`PlanBatch.timing`)
Timing = tuple[torch.Tensor, torch.Tensor, torch.Tensor]


@dataclass(frozen=True)
class GridLayout:
    """Index tensors of a batch's paths, sub-movements and sample grid (fixed for a fit).

    Path p has m_p sub-movements and ``counts[p]`` samples, its samples forming the block
    ``[block_start[p], block_end[p])`` of the flat sample tensors; consecutive samples of a
    block are joined by one segment (S = N − P). The sizes are Python ints, known without
    reading the device. ``window`` is the static number of samples a sub-movement's
    support may cover (the kinematics window K), or None to size it on every call.
    """

    n_paths: int  # P
    n_moves: int  # M
    n_samples: int  # N
    moves: torch.Tensor  # (P,) long: m_p
    counts: torch.Tensor  # (P,) long: samples of each path
    block_start: torch.Tensor  # (P,) long
    block_end: torch.Tensor  # (P,) long
    sample_path: torch.Tensor  # (N,) long
    sample_step: torch.Tensor  # (N,) long: k of sample t_k within its block
    move_path: torch.Tensor  # (M,) long
    move_block_start: torch.Tensor  # (M,) long: block of the sub-movement's path
    move_block_end: torch.Tensor  # (M,) long
    first: torch.Tensor  # (M,) bool: first sub-movement of its path
    last: torch.Tensor  # (M,) bool: last sub-movement of its path
    first_move: torch.Tensor  # (P,) long: index of each path's first sub-movement
    last_move: torch.Tensor  # (P,) long: index of each path's last sub-movement
    move_first: torch.Tensor  # (M,) long: first sub-movement of the same path
    move_point: torch.Tensor  # (M,) long: index of target p_i in ``points``
    start_point: torch.Tensor  # (P,) long: index of p0 in ``points``
    segment_start: torch.Tensor  # (S,) long: sample a segment starts at (ends at +1)
    segment_path: torch.Tensor  # (S,) long
    window: int | None = None

    @property
    def n_segments(self) -> int:
        """S = N − P: no segment crosses a pen lift."""
        return self.n_samples - self.n_paths

    def with_window(self, window: int | None) -> GridLayout:
        """The same layout with a static kinematics window of ``window`` samples."""
        return dataclasses.replace(self, window=window)

    @classmethod
    def build(cls, moves: torch.Tensor, n_moves: int, counts: torch.Tensor | None = None,
              samples_per_move: int = SAMPLES_PER_MOVE,
              n_samples: int | None = None) -> GridLayout:
        """The layout of paths with ``moves`` (P,) sub-movements (Σ = ``n_moves``).

        Without ``counts`` the grid is the fitting grid, ``samples_per_move``·m_p + 1
        samples per path, whose size N = samples_per_move·M + P needs no device read;
        with ``counts`` (P,) the size is ``n_samples`` when given, else read once.
        """
        dev = moves.device
        n_paths = moves.shape[0]
        if counts is None:
            counts = moves * samples_per_move + 1
            n_samples = samples_per_move * n_moves + n_paths
        elif n_samples is None:
            n_samples = int(counts.sum())  # one read, when the layout is built
        paths = torch.arange(n_paths, device=dev)
        block_end = torch.cumsum(counts, 0)  # (P,)
        block_start = block_end - counts
        sample_path = torch.repeat_interleave(paths, counts, output_size=n_samples)  # (N,)
        sample_step = torch.arange(n_samples, device=dev) - block_start[sample_path]
        move_path = torch.repeat_interleave(paths, moves, output_size=n_moves)  # (M,)
        last_move = torch.cumsum(moves, 0) - 1  # (P,)
        first_move = last_move + 1 - moves
        first = torch.zeros(n_moves, dtype=torch.bool, device=dev)
        first[first_move] = True
        last = torch.zeros_like(first)
        last[last_move] = True
        # target p_i of move i: its index among moves + path index + 1 (p0 per path)
        move_point = torch.arange(n_moves, device=dev) + move_path + 1
        segment_path = torch.repeat_interleave(paths, counts - 1,
                                               output_size=n_samples - n_paths)  # (S,)
        segment_start = torch.arange(n_samples - n_paths, device=dev) + segment_path
        return cls(n_paths, n_moves, n_samples, moves, counts, block_start, block_end,
                   sample_path, sample_step, move_path, block_start[move_path],
                   block_end[move_path], first, last, first_move, last_move,
                   first_move[move_path], move_point, first_move + paths, segment_start,
                   segment_path)


@dataclass
class PlanBatch:
    points: torch.Tensor  # (Σ(m_p+1), D)
    delta_t: torch.Tensor  # (M,)
    delta: torch.Tensor  # (M,)
    ac: torch.Tensor  # (M,)
    T: torch.Tensor  # (M,)
    moves: torch.Tensor  # (P,) long: m_p
    widths: torch.Tensor  # (P,)

    @classmethod
    def from_plans(cls, plans: list[MotorPlan]) -> PlanBatch:
        assert plans, "at least one plan"
        dims = {p.dim for p in plans}
        assert len(dims) == 1, f"plans mix 2-D and 3-D points: {dims}"
        ref = plans[0].points
        cat = lambda k: torch.cat([getattr(p, k) for p in plans])  # noqa: E731
        return cls(
            cat("points"), cat("delta_t"), cat("delta"), cat("ac"), cat("T"),
            torch.tensor([p.m for p in plans], dtype=torch.long, device=ref.device),
            torch.tensor([p.width for p in plans], dtype=ref.dtype, device=ref.device),
        )

    def to_plans(self) -> list[MotorPlan]:
        plans = []
        pts = torch.split(self.points, (self.moves + 1).tolist())
        per = [torch.split(getattr(self, k), self.moves.tolist())
               for k in ("delta_t", "delta", "ac", "T")]
        for i, p in enumerate(pts):
            plans.append(MotorPlan(p, per[0][i], per[1][i], per[2][i], per[3][i],
                                   float(self.widths[i])))
        return plans

    # --- index structure (derived from ``moves`` only) ---------------------------------
    @property
    def n_paths(self) -> int:
        return int(self.moves.shape[0])

    @property
    def n_moves(self) -> int:
        return int(self.delta_t.shape[0])

    def layout(self, counts: torch.Tensor | None = None,
               samples_per_move: int = SAMPLES_PER_MOVE,
               n_samples: int | None = None) -> GridLayout:
        """The :class:`GridLayout` of this batch: the fitting grid (``samples_per_move``·m_p
        + 1 samples per path), or ``counts`` (P,) samples per path (Σ = ``n_samples``)."""
        return GridLayout.build(self.moves, self.n_moves, counts, samples_per_move, n_samples)

    def move_path(self, layout: GridLayout | None = None) -> torch.Tensor:
        """(M,) path index of every sub-movement."""
        return (layout or self.layout()).move_path

    def first_last(self, layout: GridLayout | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """(M,) bool masks of each path's first and last sub-movement."""
        layout = layout or self.layout()
        return layout.first, layout.last

    def displacements(self, layout: GridLayout | None = None) -> torch.Tensor:
        """(M, D) d_i = p_i − p_{i−1}, within each path."""
        idx = (layout or self.layout()).move_point
        return self.points.index_select(0, idx) - self.points.index_select(0, idx - 1)

    def start_points(self, layout: GridLayout | None = None) -> torch.Tensor:
        """(P, D) p0 of each path."""
        return self.points.index_select(0, (layout or self.layout()).start_point)

    def timing(self, layout: GridLayout | None = None) -> Timing:
        """σ, μ, t0, each (M,)."""
        sigma, mu = sigma_mu(self.ac, self.T)
        return sigma, mu, onsets(self.delta_t, self.T, sigma, mu, layout or self.layout())

    def end_times(self, layout: GridLayout | None = None,
                  timing: Timing | None = None) -> torch.Tensor:
        """(P,) T_end of each path; ``timing``: :meth:`timing` of ``layout`` when the
        caller has it (a fit's step uses it twice: one graph, not two)."""
        layout = layout or self.layout()
        sigma, mu, t0 = timing if timing is not None else self.timing(layout)
        return end_times(t0, sigma, mu, layout)
