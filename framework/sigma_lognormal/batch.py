"""Several motor plans packed into flat tensors, so every step is one batched evaluation.

Path p owns points ``points[pt_start[p] : pt_start[p] + m_p + 1]`` and sub-movements
``[mv_start[p], mv_start[p] + m_p)`` of the per-sub-movement tensors. The optimiser keeps
these flat tensors as its leaves; :meth:`PlanBatch.to_plans` turns them back into plans.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from inkmotion.sigma_lognormal.params import end_times, onsets, sigma_mu
from inkmotion.sigma_lognormal.plan import MotorPlan


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

    def move_path(self) -> torch.Tensor:
        """(M,) path index of every sub-movement."""
        return torch.repeat_interleave(torch.arange(self.n_paths, device=self.moves.device),
                                       self.moves)

    def first_last(self) -> tuple[torch.Tensor, torch.Tensor]:
        """(M,) bool masks of each path's first and last sub-movement."""
        ends = torch.cumsum(self.moves, 0)
        starts = ends - self.moves
        first = torch.zeros(self.n_moves, dtype=torch.bool, device=self.moves.device)
        last = torch.zeros_like(first)
        first[starts] = True
        last[ends - 1] = True
        return first, last

    def displacements(self) -> torch.Tensor:
        """(M, D) d_i = p_i − p_{i−1}, within each path."""
        path = self.move_path()
        # point index of p_i for move i: its index among moves + path index + 1
        idx = torch.arange(self.n_moves, device=self.moves.device) + path + 1
        return self.points[idx] - self.points[idx - 1]

    def start_points(self) -> torch.Tensor:
        """(P, D) p0 of each path."""
        starts = torch.cumsum(self.moves + 1, 0) - (self.moves + 1)
        return self.points[starts]

    def timing(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """σ, μ, t0, each (M,)."""
        sigma, mu = sigma_mu(self.ac, self.T)
        first, _ = self.first_last()
        return sigma, mu, onsets(self.delta_t, self.T, sigma, mu, first)

    def end_times(self) -> torch.Tensor:
        """(P,) T_end of each path."""
        sigma, mu, t0 = self.timing()
        _, last = self.first_last()
        return end_times(t0, sigma, mu, last)
