"""Comparing a plan.json written now with one written on another machine.

A fit is an optimisation of float32 numbers through BLAS products, and the BLAS kernel a
machine picks (MKL's code path for its instruction set, oneDNN's, torch's vector width) moves
the last bits of each step; a few hundred Adam steps carry that on. The virtual targets are
the ill-conditioned part of a plan: a target can move tens of px while the motion it
draws (its ΣΛ trajectory, where the timing and the neighbouring targets compensate) moves
about a pixel. Measured on one machine by running the same job.json with MKL_CBWR set to
AVX, AVX2, AVX512 and COMPATIBLE, against the plans stored here (written on other machines):

=============================  ====================  ============================
job                             targets moved (px)    drawn motion (Hausdorff, px)
=============================  ====================  ============================
tests/data/v1_job (40 steps)    up to 0.29            up to 0.37
tests/data/v4_jobs/fit          up to 0.09            up to 0.14
tests/data/v3_job (edits kept   up to 32.5            up to 1.16
blindly, spec version 3)
=============================  ====================  ============================

So a plan is compared as a person would look at it: the same paths with the same number of
moves and the same widths, and motions that draw the same lines within a tolerance a few
times those figures. A change of behaviour (another default, another initialiser, an edit
that drops a move) changes the plan's size or moves the motion by far more.
"""

from __future__ import annotations

from pathlib import Path

from inkmotion.geometry.chamfer import chamfer
from inkmotion.outputs.sampling import sample
from inkmotion.sigma_lognormal.plan import Drawing

#: px: how far a fitted motion may move between machines (see the table above)
MOTION_TOLERANCE_PX = 1.0
#: px: the same for a spec-version-3 fit, whose plan edits are kept without a check
BLIND_EDITS_TOLERANCE_PX = 3.0


def assert_same_motion(new: Path, old: Path, tolerance_px: float = MOTION_TOLERANCE_PX) -> None:
    """The plans in ``new`` and ``old`` (plan.json files) have the same canvas, paths, moves
    and widths, and each path's motion lies within ``tolerance_px`` of the old one's
    (Hausdorff distance of the sampled ΣΛ trajectories)."""
    a, b = Drawing.load(new), Drawing.load(old)
    assert a.canvas == b.canvas
    assert [p.m for p in a.plans] == [p.m for p in b.plans], "moves per path"
    assert [p.width for p in a.plans] == [p.width for p in b.plans], "widths"
    for i, (pa, pb) in enumerate(zip(a.plans, b.plans, strict=True)):
        _, worst = chamfer([sample(pa).positions], [sample(pb).positions])
        assert worst <= tolerance_px, f"path {i}: the motion moved {worst:.2f} px"
