"""Calibration (paper, "Executing ΣΛ trajectories with a robot"): the drawing plane from four
taught corners, and the map from the plan's canvas (px) onto the paper (m).

Plane frame. The four points p0..p3, taught in order around the rectangle, are fitted by
the least-squares plane through their centroid c (SVD of P − c: the normal n is the right
singular vector of the smallest singular value s3; the RMS distance of the points to that
plane is s3 / 2). n is oriented towards :data:`ROBOT_SIDE`, a point on the robot's side of
any board it can draw on, so the pen points along −n. The x axis is the mean direction of
the two edges p0→p1 and p3→p2 projected into the plane (the paper's width runs along it),
y = n × x. The origin is the rectangle's corner where u, v ≥ 0 over the paper: p0 when
the points run counter-clockwise seen from the robot's side, p3 when they run clockwise
(projected onto the plane either way). Teach p0→p1 along the paper's bottom edge as seen
from where the drawing should be read, counter-clockwise, and the origin is p0.

Canvas → paper. Image y runs down, plane v up (n × u, seen from the normal's side), so
``v = v_top − s·y``: the drawing reads unmirrored when the board is looked at from the
robot's side with u to the right (a reflection, det < 0, as between any y-down image
and a right-handed frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkmotion.errors import InputError

#: a point on the robot's side of any board it can draw on (base frame, m): above the
#: shoulder (0.333 m) and below the top of the Panda's reach, so a table or stand below
#: 1 m gets an upward normal, and a wall or a lectern in front of the robot one facing it
ROBOT_SIDE = np.array([0.0, 0.0, 1.0])
#: RMS distance (m) of the taught points to their plane above which they are refused
PLANE_TOLERANCE = 0.002
#: shortest side (m) of the taught rectangle
MIN_SIDE = 0.05
#: smallest area of the taught quadrilateral relative to the product of two adjacent sides
#: (sin of its corner angle for a parallelogram: 0.5 ⇔ 30°); catches collinear and
#: crossed (mis-ordered) corners
MIN_SQUARENESS = 0.5


@dataclass(frozen=True)
class DrawingPlane:
    """The calibrated drawing plane: origin (3,) m, rotation (3, 3) with columns x, y and
    the normal n = x × y (pointing away from the board, towards the robot), all in the
    robot's base frame; ``residual`` the RMS distance of the taught points to the plane
    (m); ``size`` the taught rectangle's (width, height) m along x and y (mean of the
    opposite sides)."""

    origin: np.ndarray  # (3,)
    rotation: np.ndarray  # (3, 3)
    residual: float
    size: tuple[float, float]

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal, pointing away from the board (the pen points along −normal)."""
        return self.rotation[:, 2]

    @classmethod
    def from_points(cls, points: np.ndarray, source: str = "setup",
                    tolerance: float = PLANE_TOLERANCE) -> DrawingPlane:
        """Fit the plane of four corners ``points`` (4, 3) m, taught in order around the
        rectangle (see the module docstring for the frame). Raises ``InputError`` (naming
        ``source``) for non-finite, degenerate (a side < 5 cm, collinear or crossed) or
        non-planar points (RMS residual > ``tolerance`` m)."""
        p = np.asarray(points, dtype=float)
        if p.shape != (4, 3) or not np.all(np.isfinite(p)):
            raise InputError(f"{source}: the plane needs four finite corner points [x, y, z] "
                             f"in metres, got an array of shape {p.shape}; teach four corners.")
        sides = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)  # |p_{i+1} − p_i|
        if sides.min() < MIN_SIDE:
            i = int(np.argmin(sides))
            raise InputError(
                f"{source}: the side from corner {i} to corner {(i + 1) % 4} of the plane is "
                f"{sides[i] * 1e3:.1f} mm long, shorter than {MIN_SIDE * 1e3:.0f} mm; teach "
                "the corners of the drawing area, in order around it.")
        vector_area = 0.5 * np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
        squareness = np.linalg.norm(vector_area) / (0.5 * (sides[0] + sides[2])
                                                    * 0.5 * (sides[1] + sides[3]))
        if squareness < MIN_SQUARENESS:
            raise InputError(
                f"{source}: the four plane corners enclose {squareness:.0%} of the area of a "
                f"rectangle with the same sides (at least {MIN_SQUARENESS:.0%} needed), so they "
                "are collinear or out of order; teach them in order around the rectangle.")
        centroid = p.mean(axis=0)
        _, s, vt = np.linalg.svd(p - centroid)
        residual = float(s[2] / 2.0)  # sqrt(s3² / 4): RMS distance to the plane
        if residual > tolerance:
            raise InputError(
                f"{source}: the four plane corners are not coplanar (RMS distance "
                f"{residual * 1e3:.2f} mm to their best plane, tolerance "
                f"{tolerance * 1e3:.2f} mm); teach them again on the flat drawing pad.")
        normal = vt[2]
        side = float((ROBOT_SIDE - centroid) @ normal)
        if abs(side) < 0.01:
            raise InputError(f"{source}: the plane of the four corners passes within 1 cm of "
                             f"{ROBOT_SIDE.tolist()} m, so its robot side is undefined; "
                             "place the drawing pad in front of the robot.")
        normal = normal if side > 0 else -normal
        edges = (p[1] - p[0]) + (p[2] - p[3])
        x = edges - (edges @ normal) * normal
        x /= np.linalg.norm(x)
        y = np.cross(normal, x)
        rotation = np.column_stack((x, y, normal))
        uv = (p - centroid) @ rotation[:, :2]  # (4, 2)
        shoelace = 0.5 * float(np.sum(uv[:, 0] * np.roll(uv[:, 1], -1)
                                      - np.roll(uv[:, 0], -1) * uv[:, 1]))
        corner = 0 if shoelace > 0 else 3  # counter-clockwise seen from the normal: p0
        origin = centroid + rotation[:, :2] @ uv[corner]
        size = (0.5 * (sides[0] + sides[2]), 0.5 * (sides[1] + sides[3]))
        return cls(origin=origin, rotation=rotation, residual=residual,
                   size=(float(size[0]), float(size[1])))

    def to_base(self, uv: np.ndarray, height: np.ndarray | float = 0.0) -> np.ndarray:
        """Points (N, 3) m in the base frame: origin + u·x + v·y + height·n for plane
        coordinates ``uv`` (N, 2) m and ``height`` (N,) m above the plane."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        h = np.broadcast_to(np.asarray(height, dtype=float), (len(uv),))
        return self.origin + uv @ self.rotation[:, :2].T + h[:, None] * self.normal

    def to_plane(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`to_base`: (uv (N, 2), height (N,)) of base-frame points (N, 3)."""
        local = (np.asarray(points, dtype=float).reshape(-1, 3) - self.origin) @ self.rotation
        return local[:, :2], local[:, 2]


@dataclass(frozen=True)
class PaperMapping:
    """Canvas px → paper (u, v) m: u = u0 + s·x, v = v_top − s·y (image y runs down, v up;
    see the module docstring), one scale ``s`` (m/px) for both axes."""

    scale: float  # s, m per px
    offset: tuple[float, float]  # (u0, v_top): plane coordinates of canvas pixel (0, 0)
    canvas: tuple[float, float]  # (W, H) px
    paper: tuple[float, float]  # (w, h) m

    @classmethod
    def from_canvas(cls, canvas: tuple[float, float], paper: tuple[float, float],
                    margin: float) -> PaperMapping:
        """The largest uniform scale s = min((w − 2·margin)/W, (h − 2·margin)/H) that fits
        the canvas inside the paper less ``margin`` on every side, centred on the paper."""
        (cw, ch), (w, h) = (float(c) for c in canvas), (float(x) for x in paper)
        assert cw > 0 and ch > 0, f"canvas must be positive, got {canvas}"
        assert w > 2 * margin and h > 2 * margin, f"margin {margin} leaves no paper of {paper}"
        s = min((w - 2 * margin) / cw, (h - 2 * margin) / ch)
        return cls(scale=s, offset=((w - s * cw) / 2, (h + s * ch) / 2), canvas=(cw, ch),
                   paper=(w, h))

    def px_to_plane(self, xy: np.ndarray) -> np.ndarray:
        """Plane coordinates (N, 2) m of canvas points ``xy`` (N, 2) px."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.column_stack((self.offset[0] + self.scale * xy[:, 0],
                                self.offset[1] - self.scale * xy[:, 1]))

    def plane_to_px(self, uv: np.ndarray) -> np.ndarray:
        """Canvas points (N, 2) px of plane coordinates ``uv`` (N, 2) m (inverse map)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        return np.column_stack(((uv[:, 0] - self.offset[0]) / self.scale,
                                (self.offset[1] - uv[:, 1]) / self.scale))

    def velocity_to_plane(self, v_xy: np.ndarray) -> np.ndarray:
        """Plane velocities (or accelerations) (N, 2) m/s of canvas ones (N, 2) px/s:
        (s·vx, −s·vy)."""
        v_xy = np.asarray(v_xy, dtype=float).reshape(-1, 2)
        return np.column_stack((self.scale * v_xy[:, 0], -self.scale * v_xy[:, 1]))
