"""The trace term of a fit: how far the fitted motion runs from the input trace, both ways.

A drawing input (a GML tag, an SVG, a word) gives the fit more than its picture: the pen's
own polylines. The image loss only sees ink where the rendered stroke and the target
overlap or nearly do (the multi-scale MSE's blur reaches a few px), so once the pen has
taken another route between two targets — a loop cut across, a corner pulled 40 px off —
nothing pulls it back. The trace term does, from any distance:

    L_trace = mean_{q ∈ Q} ρ(d(q, C)) + mean_{c ∈ F} ρ(d(c, T))

(with a tolerance τ, the fit's ``--tolerance``, each d is replaced by max(0, d − τ): the
motion may leave the trace by up to τ px at no cost, where the smoothing cost makes it
more rapid for it)

with Q the input points (every ``spacing`` px of arc along each stroke), C the fitted trajectory
as chords (each Hermite Bézier segment of the fitting grid split at t = ½), F the fitted
samples (the segments' t = 0 and t = ½ points), T the input polyline's segments, d the
point-to-segment distance in px and ρ(d) = √(d² + s²) − s the pseudo-Huber penalty
(≈ d²/2s within ``scale`` s of the trace, where the image loss works, ≈ d beyond it, so a
far miss pulls with a bounded force and cannot swamp the smoothing cost). The first mean
is the recall (every part of the input is drawn), the second the precision (the pen stays
on the input); together they are a smooth symmetric Chamfer distance.

Worst misses (spec version 6 on, the fit's ``--w-worst`` w). A mean weighs a cusp's tip
or a hook's end that the fit cuts short by its handful of points among hundreds: too
little to pull against the smoothing cost, which rounds a sharp reversal off. A third part
weighs the recall's worst misses:

    w · T · log mean_{q ∈ Q} exp(ρ(e(q)) / T),   e(q) = max(0, d(q, C) − d₀)

(d less any tolerance τ, as above)

a soft maximum (temperature T = ``WORST_SCALE`` px) of how far each input point lies
beyond d₀ = ``WORST_FROM`` px, the width of a pen, within which a miss is not one a person
would see (the 'hand' sparsity's threshold for a new target). It is 0 while every point is
within d₀, where the smoothing cost alone makes the motion rapid; beyond it, its gradient
goes to the points in proportion to exp(ρ/T), so one miss that stands out by several T
pulls as hard as the whole rest of the trace.

Which path may cover which stroke. A pen path drawn through one stroke should not take the
ink of another stroke that crosses it. A stroke is *owned* by the paths whose initial
trajectory runs along it (at least half of its points within ``own_within`` px); a
stroke's points are matched to its owners' chords only, and a path's samples to its
strokes' segments only. A stroke that no path owns, or a path that owns none (an
initialiser that does not follow the strokes, e.g. one tour through all of them), is
matched with everything. Every px constant here is for a 350-px canvas and scales with the
canvas (the reference's ``unit``), and the term is reported in those px, so a fit at
700 px weighs it as one at 350 px does. The masks are fixed for a fit stage, so a step has
static shapes and reads nothing back from the device.

Which pass of the pen. A path that crosses itself (a loop, the two f of "graffiti") passes
some places twice; the nearest chord to an input point may then be the other pass, and a
hook the fit cuts short would go unnoticed. Where a stroke and a path own only each other,
the nearest-match search therefore also weighs how far apart the two points are along the
stroke and the path (their shares of the arc length times the stroke's length): a pair
more than max(20 px, 15 % of the stroke) apart counts as farther by the excess, so a point
is matched to the pass of the pen that belongs to it. The distance itself (and its
gradient) is the plain geometric one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from inkmotion.geometry.chamfer import densify
from inkmotion.geometry.polyline import arc_length
from inkmotion.portable_math import planar_norm
from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout

#: px between the input points of the recall term
RECALL_SPACING = 3.0
#: px, s of the pseudo-Huber penalty ρ(d) = √(d² + s²) − s
HUBER_SCALE = 1.0
#: px: a stroke belongs to a path whose initial trajectory runs within this of it
OWN_WITHIN = 2.0
#: the band of the nearest-match search along a stroke and the path that follows it: pairs
#: more than max(BAND_MIN_PX, BAND_SHARE × the stroke's length) apart along the two count
#: as farther by the excess (module docstring)
BAND_MIN_PX = 20.0
BAND_SHARE = 0.15
#: px², the start of a min over pairs (larger than any canvas's squared diagonal)
FAR = 1e12
#: px, T of the worst misses' soft maximum (module docstring)
WORST_SCALE = 2.0
#: px, d₀: a miss counts among the worst only beyond this (the width of a pen)
WORST_FROM = 3.0


def simplify(stroke: np.ndarray, tolerance: float = 0.25) -> np.ndarray:
    """The vertices (k, 2) of ``stroke`` (n, ≥2) that stand more than ``tolerance`` px off
    the chord of their neighbours, removed greedily from the flattest (Douglas–Peucker
    from the ends, iterative): the precision term's segments, fewer and just as exact."""
    p = np.asarray(stroke, dtype=np.float64)[:, :2]
    if len(p) <= 2:
        return p
    keep = np.zeros(len(p), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(p) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        chord = p[b] - p[a]
        c = float(np.hypot(*chord))
        rel = p[a + 1:b] - p[a]
        if c <= 1e-12:
            h = np.hypot(rel[:, 0], rel[:, 1])
        else:
            h = np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / c
        k = int(np.argmax(h))
        if h[k] > tolerance:
            keep[a + 1 + k] = True
            stack += [(a, a + 1 + k), (a + 1 + k, b)]
    return p[keep]


def _resample(stroke: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (k, 2) every ``spacing`` px of arc along ``stroke`` (n, 2), its ends
    included (a recorded trace's own vertices are as dense as its sampling rate: they
    would weigh slow parts more), and their arc lengths (k,)."""
    arc = arc_length(stroke)
    n = max(2, math.ceil(float(arc[-1]) / spacing) + 1)
    at = np.linspace(0.0, float(arc[-1]), n)
    return np.column_stack([np.interp(at, arc, stroke[:, k]) for k in range(2)]), at


def _point_segment_d2(q: torch.Tensor, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Squared distances (n,) from points ``q`` (n, 2) to segments ``a``→``b`` (n, 2)."""
    ab = b - a
    aq = q - a
    t = ((aq * ab).sum(-1) / (ab * ab).sum(-1).clamp(min=1e-12)).clamp(0.0, 1.0)  # (n,)
    r = aq - t[:, None] * ab
    return (r * r).sum(-1)


def _pairs(rows_of: list[np.ndarray], cols_of: list[np.ndarray],
           device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """Every (row, col) of the groups g: rows_of[g] × cols_of[g], as two index tensors."""
    rows = [np.repeat(r, len(c)) for r, c in zip(rows_of, cols_of, strict=True)]
    cols = [np.tile(c, len(r)) for r, c in zip(rows_of, cols_of, strict=True)]
    return (torch.as_tensor(np.concatenate(rows), dtype=torch.long, device=device),
            torch.as_tensor(np.concatenate(cols), dtype=torch.long, device=device))


@dataclass(frozen=True)
class TraceReference:
    """The input trace on the device: recall points Q (K, 2) and precision segments T
    (J, 2 → 2), each with the stroke it belongs to, and the strokes as polylines."""

    points: torch.Tensor  # (K, 2)
    point_stroke: torch.Tensor  # (K,) long
    seg_a: torch.Tensor  # (J, 2)
    seg_b: torch.Tensor  # (J, 2)
    seg_stroke: torch.Tensor  # (J,) long
    strokes: tuple[np.ndarray, ...]
    point_arc: torch.Tensor  # (K,) share of its stroke's length before the point, 0..1
    seg_arc: torch.Tensor  # (J,) the same at the segment's midpoint
    lengths: torch.Tensor  # (n_strokes,) px
    unit: float = 1.0  # px per px of a 350-px canvas: the constants' scale

    @classmethod
    def of(cls, strokes: list[np.ndarray], *, dtype: torch.dtype, device: torch.device | str,
           unit: float = 1.0) -> TraceReference:
        """From the input ``strokes`` (canvas px; strokes of fewer than 2 points ignored);
        ``unit``: the canvas's size / 350, the scale of every px constant of this module
        (a fit at 700 px is the same problem as at 350 px, twice as large)."""
        spacing = RECALL_SPACING * unit
        kept = tuple(np.asarray(s, dtype=np.float64)[:, :2] for s in strokes if len(s) >= 2)
        assert kept, "a trace reference needs a stroke of two points"
        pts, pst, sa, sb, sst, parc, sarc, lengths = [], [], [], [], [], [], [], []
        for i, s in enumerate(kept):
            d, arc = _resample(s, spacing)
            pts.append(d)
            pst.append(np.full(len(d), i))
            v = simplify(s)
            sa.append(v[:-1])
            sb.append(v[1:])
            sst.append(np.full(len(v) - 1, i))
            length = max(float(arc[-1]), 1e-9)
            parc.append(arc / length)
            varc = arc_length(v)
            sarc.append(0.5 * (varc[:-1] + varc[1:]) / max(float(varc[-1]), 1e-9))
            lengths.append([length])

        def put(x: list[np.ndarray], kind: torch.dtype = dtype) -> torch.Tensor:
            return torch.as_tensor(np.concatenate(x), dtype=kind, device=device)

        return cls(put(pts), put(pst, torch.long), put(sa), put(sb), put(sst, torch.long),
                   kept, put(parc), put(sarc), put(lengths), float(unit))

    @classmethod
    def concat(cls, refs: list[TraceReference]) -> TraceReference:
        """Several drawings' references as one (a batched fit): their strokes numbered on,
        drawing after drawing; every drawing must have the same ``unit``."""
        assert len({r.unit for r in refs}) == 1, "drawings of one batch share a canvas size"
        offsets = np.cumsum([0] + [len(r.strokes) for r in refs[:-1]])
        cat = torch.cat
        return cls(cat([r.points for r in refs]),
                   cat([r.point_stroke + int(o) for r, o in zip(refs, offsets, strict=True)]),
                   cat([r.seg_a for r in refs]), cat([r.seg_b for r in refs]),
                   cat([r.seg_stroke + int(o) for r, o in zip(refs, offsets, strict=True)]),
                   tuple(s for r in refs for s in r.strokes),
                   cat([r.point_arc for r in refs]), cat([r.seg_arc for r in refs]),
                   cat([r.lengths for r in refs]), refs[0].unit)

    def ownership(self, initial_positions: list[np.ndarray],
                  own_within: float | None = None) -> torch.Tensor:
        """(n_strokes, P) bool: which paths may cover which stroke (module docstring), from
        each path's initial trajectory samples (n_p, ≥2)."""
        from scipy.spatial import cKDTree

        own_within = OWN_WITHIN * self.unit if own_within is None else own_within
        n, paths = len(self.strokes), len(initial_positions)
        own = np.zeros((n, paths), dtype=bool)
        # one tree over every path's samples, labelled by path: each stroke asks it once
        # which paths pass within reach of each of its points (a tree per path asked per
        # stroke was paths × strokes queries: 150 s for a drawing of 1000 short strokes)
        samples = [densify(np.asarray(xy)[:, :2], 0.5) for xy in initial_positions]
        label = np.repeat(np.arange(paths), [len(xy) for xy in samples])
        tree = cKDTree(np.concatenate(samples))
        for s, stroke in enumerate(self.strokes):
            near = tree.query_ball_point(densify(stroke, 1.0), own_within)  # (k,) lists
            points = np.repeat(np.arange(len(near)), [len(i) for i in near])
            hit = np.zeros((len(near), paths), dtype=bool)  # point k within reach of path p
            hit[points, label[np.concatenate(near).astype(np.intp)]] = True
            own[s] = hit.mean(axis=0) >= 0.5
        own[~own.any(axis=1), :] = True  # a stroke nobody follows: anyone may cover it
        own[:, ~own.any(axis=0)] = True  # a path that follows no stroke: it may cover any
        return torch.as_tensor(own, device=self.points.device)


def _group_ranges(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each element of ``group`` (n,), sorted (its runs are contiguous), the first and
    last index of its run."""
    return (np.searchsorted(group, group, side="left"),
            np.searchsorted(group, group, side="right") - 1)


def _nearest(d2: torch.Tensor, rows: torch.Tensor, cols: torch.Tensor,
             n_rows: int) -> torch.Tensor:
    """For each row, the col of its pair with the smallest ``d2`` (n_rows,) long; every row
    has a pair. On the device, no host read. A row whose distances are all NaN (a motion
    gone non-finite) gets col 0, a valid index: the loss is then NaN, which the optimiser
    reports in one sentence."""
    best = d2.new_full((n_rows,), FAR).scatter_reduce(0, rows, d2, "amin",
                                                       include_self=False)
    hit = torch.where(d2 <= best[rows], cols, -1)
    return torch.full((n_rows,), -1, dtype=torch.long, device=d2.device).scatter_reduce(
        0, rows, hit, "amax", include_self=True).clamp_(min=0)


class TraceLoss:
    """L_trace of a fit stage (module docstring): call with the fitting grid's Bézier
    segments (S, 4, D) and their layout; returns a 0-d tensor (px of a 350-px canvas:
    the canvas's px divided by the reference's ``unit``).

    The nearest chord of every recall point and the nearest input segment of every fitted
    sample are searched, without gradient, over the pairs the ownership allows (index
    pairs built once per layout) every ``refresh`` calls; each call then measures the
    distance to that one and its ``reach`` neighbours on either side along the same path
    or stroke. The motion moves by a fraction of a px per step, so the minimum is found
    among them, at a cost linear in the input's length and the plan's size."""

    def __init__(self, reference: TraceReference, owners: torch.Tensor,
                 scale: float | None = None, refresh: int = 20, reach: int = 2,
                 tolerance: float = 0.0, worst: float = 0.0) -> None:
        self.ref = reference
        scale = HUBER_SCALE * reference.unit if scale is None else scale
        #: canvas px within which a distance costs nothing: ρ(max(0, d − tolerance))
        self.tolerance = float(tolerance)
        #: w of the worst misses' soft maximum (module docstring; 0: none), its T and d₀
        #: in canvas px
        self.worst = float(worst)
        self.worst_scale = WORST_SCALE * reference.unit
        self.worst_from = WORST_FROM * reference.unit
        self.owners = owners.cpu().numpy()  # (n_strokes, P) bool
        self.scale = scale
        self.refresh, self.reach = refresh, reach
        self._layout: GridLayout | None = None
        self._pairs: tuple[torch.Tensor, ...] = ()
        self._ranges: tuple[torch.Tensor, ...] = ()
        self._near: tuple[torch.Tensor, torch.Tensor] | None = None
        offsets = torch.arange(-reach, reach + 1, device=reference.points.device)
        self._offsets = offsets  # (2·reach + 1,)
        # each input segment's stroke range [first, last] (J,), for the neighbours
        stroke = reference.seg_stroke.cpu().numpy()
        first, last = _group_ranges(stroke)
        self._seg_range = (torch.as_tensor(first, device=offsets.device),
                           torch.as_tensor(last, device=offsets.device))
        self._union: _Union | None = None  # set by :meth:`union`

    @classmethod
    def union(cls, losses: list[TraceLoss], path_counts: list[int]) -> TraceLoss:
        """The terms of several drawings fitted together (drawing b owns the next
        ``path_counts[b]`` paths of the batch): one term whose call returns each drawing's
        L_trace (B,), its strokes matched to its own paths only."""
        first = losses[0]
        ref = TraceReference.concat([t.ref for t in losses])
        owners = np.zeros((sum(t.owners.shape[0] for t in losses), sum(path_counts)),
                          dtype=bool)
        row = col = 0
        for t, paths in zip(losses, path_counts, strict=True):
            assert t.owners.shape[1] == paths, (t.owners.shape, paths)
            owners[row:row + t.owners.shape[0], col:col + paths] = t.owners
            row, col = row + t.owners.shape[0], col + paths
        joined = cls(ref, torch.as_tensor(owners), first.scale, first.refresh, first.reach,
                     first.tolerance, first.worst)
        device = ref.points.device
        items = len(losses)
        joined._union = _Union(
            items=items,
            path_item=torch.as_tensor(np.repeat(np.arange(items), path_counts), device=device),
            point_item=torch.as_tensor(np.repeat(np.arange(items),
                                                 [t.ref.points.shape[0] for t in losses]),
                                       device=device),
            points=[t.ref.points.shape[0] for t in losses],
            segments=[t.ref.seg_a.shape[0] for t in losses])
        return joined

    def item_states(self) -> list[dict[str, torch.Tensor]]:
        """A union's :meth:`state` split into each drawing's own (its own numbering)."""
        u = self._union
        assert u is not None, "item_states is for a union of terms"
        if self._near is None:
            return [{} for _ in range(u.items)]
        chord, segment = self._near
        out = []
        k = s2 = j = 0
        for b in range(u.items):
            n_k, n_s2, n_j = u.points[b], u.samples[b], u.segments[b]
            out.append({"chord": chord[k:k + n_k] - s2, "segment": segment[s2:s2 + n_s2] - j})
            k, s2, j = k + n_k, s2 + n_s2, j + n_j
        return out

    def load_item_states(self, states: list[dict[str, torch.Tensor]]) -> None:
        """Continue a union with its drawings' own states (after its first call)."""
        u = self._union
        assert u is not None and len(states) == u.items
        if not all(states):
            return
        device = self.ref.points.device
        chords, segments = [], []
        s2 = j = 0
        for b, state in enumerate(states):
            chords.append(state["chord"].to(device) + s2)
            segments.append(state["segment"].to(device) + j)
            s2, j = s2 + u.samples[b], j + u.segments[b]
        self._near = (torch.cat(chords), torch.cat(segments))

    def state(self) -> dict[str, torch.Tensor]:
        """The current matches (for a checkpoint); empty before the first step."""
        if self._near is None:
            return {}
        return {"chord": self._near[0].clone(), "segment": self._near[1].clone()}

    def load_state(self, state: dict[str, torch.Tensor]) -> None:
        """Continue with :meth:`state`'s matches (after the layout's first call)."""
        if state:
            device = self.ref.points.device
            self._near = (state["chord"].to(device), state["segment"].to(device))

    def _build(self, layout: GridLayout) -> None:
        """The layout's index pairs (recall point, chord), (sample, input segment) and each
        chord's path range; the next call searches the nearest ones."""
        device = self.ref.points.device
        half_path = layout.segment_path.repeat_interleave(2).cpu().numpy()  # (2S,)
        point_stroke = self.ref.point_stroke.cpu().numpy()
        seg_stroke = self.ref.seg_stroke.cpu().numpy()
        strokes, paths = range(self.owners.shape[0]), range(self.owners.shape[1])
        recall = _pairs([np.flatnonzero(point_stroke == s) for s in strokes],
                        [np.flatnonzero(self.owners[s][half_path]) for s in strokes], device)
        precision = _pairs([np.flatnonzero(half_path == p) for p in paths],
                           [np.flatnonzero(self.owners[seg_stroke, p]) for p in paths], device)
        first, last = _group_ranges(half_path)
        self._pairs = recall + precision
        # a stroke and a path that own only each other: their pairs are banded
        one = (self.owners.sum(1) == 1)[:, None] & (self.owners.sum(0) == 1)[None, :] \
            & self.owners  # (n_strokes, P)
        rk, rc, ps, pj = (t.cpu().numpy() for t in self._pairs)
        self._recall_banded = torch.as_tensor(one[point_stroke[rk], half_path[rc]],
                                              device=device)
        self._precision_banded = torch.as_tensor(one[seg_stroke[pj], half_path[ps]],
                                                 device=device)
        self._ranges = (torch.as_tensor(first, device=device),
                        torch.as_tensor(last, device=device))
        self._layout, self._near = layout, None
        if self._union is not None:
            u = self._union
            u.sample_item = u.path_item[layout.segment_path].repeat_interleave(2)
            u.samples = np.bincount(u.path_item.cpu().numpy()[half_path],
                                    minlength=u.items).tolist()

    def _search(self, starts: torch.Tensor, ends: torch.Tensor) -> None:
        """The nearest chord of every recall point and the nearest input segment of every
        fitted sample (no gradient). Where a stroke and a path own only each other, a pair
        far apart along the two (by more than the band, module docstring) counts as
        farther: a pass of the pen over the same spot at another time is not the match."""
        rk, rc, ps, pj = self._pairs
        ref = self.ref
        with torch.no_grad():
            first, last = self._ranges
            length = planar_norm(ends - starts)  # (2S,) chord lengths
            after = length.cumsum(0)
            before = after - length
            done = before - before[first]  # arc of the path before each chord
            share = (done + 0.5 * length) / (after[last] - before[first]).clamp(min=1e-9)
            stroke_len = ref.lengths[ref.point_stroke]  # (K,)
            d2 = _point_segment_d2(ref.points[rk], starts[rc], ends[rc]) + self._band(
                ref.point_arc[rk] - share[rc], stroke_len[rk], self._recall_banded,
                ref.unit)
            chord = _nearest(d2, rk, rc, ref.points.shape[0])
            d2 = _point_segment_d2(starts[ps], ref.seg_a[pj], ref.seg_b[pj]) + self._band(
                share[ps] - ref.seg_arc[pj], ref.lengths[ref.seg_stroke[pj]],
                self._precision_banded, ref.unit)
            segment = _nearest(d2, ps, pj, starts.shape[0])
        self._near = (chord, segment)

    @staticmethod
    def _band(offset: torch.Tensor, length: torch.Tensor, banded: torch.Tensor,
              unit: float) -> torch.Tensor:
        """px²: the squared excess of |offset|·length (px along the stroke) over the band
        max(BAND_MIN_PX·unit, BAND_SHARE·length), where ``banded``; 0 elsewhere."""
        band = torch.clamp(BAND_SHARE * length, min=BAND_MIN_PX * unit)
        excess = torch.relu(offset.abs() * length - band)
        return torch.where(banded, excess * excess, 0.0)

    def _around(self, nearest: torch.Tensor, first: torch.Tensor,
                last: torch.Tensor) -> torch.Tensor:
        """(n, 2·reach + 1): ``nearest`` and its neighbours, clamped to its own range."""
        lo = first.index_select(0, nearest)[:, None]
        hi = last.index_select(0, nearest)[:, None]
        return torch.minimum(torch.maximum(nearest[:, None] + self._offsets, lo), hi)

    @staticmethod
    def _beyond(d2: torch.Tensor, within: float) -> torch.Tensor:
        """max(0, d − within)² of squared distances ``d2`` (zero gradient inside)."""
        return (d2.clamp_min(1e-12).sqrt() - within).clamp_min(0.0).square()

    def __call__(self, segments: torch.Tensor, layout: GridLayout,
                 step: int | None = None) -> torch.Tensor:
        """L_trace of ``segments``; ``step`` (1-based, an optimiser step) searches the
        matches again on steps 1, 1 + refresh, ... and keeps them for the steps between;
        without a step (an evaluation outside the loop) the matches are searched for this
        call alone. The matches are the only state: :meth:`state` / :meth:`load_state`
        carry them through a checkpoint, so a resumed fit repeats the same arithmetic."""
        if layout is not self._layout:
            self._build(layout)
        p0, p1, p2, p3 = (segments[:, k, :2] for k in range(4))  # (S, 2) each
        eighth, three = scalar_tensors(segments, 0.125, 3.0)
        half = eighth * (p0 + three * p1 + three * p2 + p3)  # B(½)
        starts = torch.stack((p0, half), 1).reshape(-1, 2)  # (2S, 2) samples F
        ends = torch.stack((half, p3), 1).reshape(-1, 2)  # chords C: start → end
        kept = self._near
        if step is None or kept is None or (step - 1) % self.refresh == 0:
            self._search(starts, ends)
        if step is None:
            kept, self._near = self._near, kept
        else:
            kept = self._near
        assert kept is not None
        chord, segment = kept
        ref, w = self.ref, self._offsets.numel()
        c = self._around(chord, *self._ranges)  # (K, w)
        q = ref.points[:, None, :].expand(-1, w, -1).reshape(-1, 2)
        c = c.reshape(-1)
        recall = _point_segment_d2(q, starts.index_select(0, c), ends.index_select(0, c))
        j = self._around(segment, *self._seg_range).reshape(-1)  # (2S·w,)
        f = starts[:, None, :].expand(-1, w, -1).reshape(-1, 2)
        precision = _point_segment_d2(f, ref.seg_a.index_select(0, j),
                                      ref.seg_b.index_select(0, j))
        s2, scale = scalar_tensors(segments, self.scale * self.scale, self.scale)
        recall, precision = recall.view(-1, w).amin(1), precision.view(-1, w).amin(1)
        if self.tolerance > 0:  # squared distances beyond the tolerance band
            recall = self._beyond(recall, self.tolerance)
            precision = self._beyond(precision, self.tolerance)
        worst = None
        if self.worst > 0:  # ρ(e) / T of every recall point (module docstring)
            excess = self._beyond(recall, self.worst_from)
            worst = ((excess + s2).sqrt() - scale) / self.worst_scale
        recall = (recall + s2).sqrt()  # (K,) ρ + s
        precision = (precision + s2).sqrt()  # (2S,) ρ + s
        if self._union is not None:  # each drawing's own means (B,)
            u = self._union
            total = u.mean(recall, u.point_item) + u.mean(precision, u.sample_item)
            if worst is not None:
                total = total + self.worst * self.worst_scale * u.log_mean_exp(
                    worst, u.point_item)
            return (total - 2.0 * self.scale) / self.ref.unit
        total = recall.mean() + precision.mean()
        if worst is not None:
            top = worst.detach().max()
            total = total + self.worst * self.worst_scale * (
                top + (worst - top).exp().mean().log())
        return (total - 2.0 * self.scale) / self.ref.unit


@dataclass
class _Union:
    """Which drawing each path, recall point and fitted sample of a union belongs to."""

    items: int
    path_item: torch.Tensor  # (P,) long
    point_item: torch.Tensor  # (K,) long
    points: list[int]  # K_b
    segments: list[int]  # J_b
    sample_item: torch.Tensor | None = None  # (2S,) long, per layout
    samples: list[int] = field(default_factory=list)  # 2·S_b, per layout

    def mean(self, values: torch.Tensor, item: torch.Tensor | None) -> torch.Tensor:
        """Each drawing's mean of ``values`` (n,) (B,)."""
        assert item is not None
        zeros = values.new_zeros(self.items)
        return zeros.index_add(0, item, values) / zeros.index_add(0, item,
                                                                   torch.ones_like(values))

    def log_mean_exp(self, values: torch.Tensor, item: torch.Tensor) -> torch.Tensor:
        """Each drawing's log mean exp of ``values`` (n,) (B,), shifted by its own largest
        value (detached: the shift cancels, exactly, in value and gradient), as a drawing
        alone computes it."""
        top = values.detach().new_full((self.items,), -math.inf).scatter_reduce(
            0, item, values.detach(), "amax")
        return top + (self.mean((values - top[item]).exp(), item)).log()
