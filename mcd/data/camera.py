"""Cameras, camera paths and motion vectors (docs/benchmark.md, "Camera"; docs/architecture.md, buffer
`motion`).

A camera is Mitsuba's perspective sensor: a 4x4 ``to_world`` whose columns are (left, up, forward, origin)
(Mitsuba's ``look_at`` convention) and a horizontal field of view ``fov`` in degrees (``fov_axis = "x"``).
Pixel (x, y) has its centre at (x + 0.5, y + 0.5); x grows to the right (towards -left), y grows downwards.

Paths go through key nodes: positions are interpolated linearly and orientations by quaternion slerp
(scipy's ``Slerp``), ``frames_per_segment`` frames per segment.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: world transform (4x4, columns left/up/forward/origin), horizontal fov, film size."""

    to_world: np.ndarray
    fov: float
    width: int
    height: int

    def to_dict(self) -> dict:
        """JSON form stored per frame in the manifest."""
        return {
            "to_world": np.asarray(self.to_world, dtype=float).round(9).tolist(),
            "fov": float(self.fov),
            "fov_axis": "x",
            "width": int(self.width),
            "height": int(self.height),
        }

    @staticmethod
    def from_dict(d: dict) -> Camera:
        return Camera(
            np.asarray(d["to_world"], dtype=np.float64), float(d["fov"]), int(d["width"]), int(d["height"])
        )

    @property
    def origin(self) -> np.ndarray:
        return np.asarray(self.to_world, dtype=np.float64)[:3, 3]

    def _tans(self) -> tuple[float, float]:
        tx = float(np.tan(np.radians(self.fov) / 2))
        return tx, tx * self.height / self.width

    def pixel_directions(self) -> np.ndarray:
        """Unit world-space ray directions through every pixel centre, ``(H, W, 3)``."""
        tx, ty = self._tans()
        u = (np.arange(self.width) + 0.5) / self.width
        v = (np.arange(self.height) + 0.5) / self.height
        uu, vv = np.meshgrid(u, v)
        local = np.stack([-(2 * uu - 1) * tx, -(2 * vv - 1) * ty, np.ones_like(uu)], axis=-1)
        local /= np.linalg.norm(local, axis=-1, keepdims=True)
        rot = _rotation_part(self.to_world)
        return local @ rot.T

    def project(
        self, points: np.ndarray, at_infinity: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates ``(..., 2)`` of world points, and a mask of points in front.

        Where `at_infinity` is True, `points` holds directions (points at infinity, e.g. the environment).
        """
        rot = _rotation_part(self.to_world)
        rel = points - self.origin
        if at_infinity is not None:
            rel = np.where(at_infinity[..., None], points, rel)
        local = rel @ rot  # = rot.T @ rel per point
        tx, ty = self._tans()
        z = local[..., 2]
        front = z > 1e-9
        zs = np.where(front, z, 1.0)
        px = 0.5 * self.width * (1 - local[..., 0] / (zs * tx))
        py = 0.5 * self.height * (1 - local[..., 1] / (zs * ty))
        return np.stack([px, py], axis=-1), front


def _rotation_part(to_world: np.ndarray) -> np.ndarray:
    """The 3x3 orientation of a camera transform with its columns normalised (scale removed)."""
    m = np.asarray(to_world, dtype=np.float64)[:3, :3]
    return m / np.linalg.norm(m, axis=0, keepdims=True)


def look_at(origin: Sequence[float], target: Sequence[float], up: Sequence[float]) -> np.ndarray:
    """Mitsuba's ``ScalarTransform4f.look_at`` as a NumPy 4x4 (columns left, up, forward, origin)."""
    o, t, u = (np.asarray(v, dtype=np.float64) for v in (origin, target, up))
    d = t - o
    d /= np.linalg.norm(d)
    left = np.cross(u, d)
    n = np.linalg.norm(left)
    if n < 1e-9:
        raise ValueError(f"look_at: up {up} is parallel to the view direction {d.tolist()}")
    left /= n
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


def interpolate_path(nodes: Sequence[np.ndarray], frames_per_segment: int) -> list[np.ndarray]:
    """Camera transforms along key nodes: linear positions, slerped orientations.

    Gives ``(len(nodes) - 1) * frames_per_segment`` frames; frame ``i`` sits at parameter
    ``i / frames_per_segment`` (so node k is frame ``k * frames_per_segment``; the last node itself is the end
    of the path and is not a frame). Mirrored transforms (det < 0) keep their handedness.
    """
    if len(nodes) < 2:
        raise ValueError("a camera path needs at least two key nodes")
    if frames_per_segment < 1:
        raise ValueError(f"frames_per_segment must be >= 1, got {frames_per_segment}")
    mats = [np.asarray(n, dtype=np.float64) for n in nodes]
    rots = [_rotation_part(m) for m in mats]
    sign = np.sign(np.linalg.det(rots[0]))
    if any(np.sign(np.linalg.det(r)) != sign for r in rots):
        raise ValueError("camera key nodes mix mirrored and unmirrored transforms")
    flip = np.diag([sign, 1.0, 1.0])
    scales = [np.linalg.norm(m[:3, :3], axis=0) for m in mats]
    key_t = np.arange(len(mats), dtype=np.float64)
    from scipy.spatial.transform import Rotation, Slerp  # on first use: a fast start (docs/architecture.md)

    slerp = Slerp(key_t, Rotation.from_matrix(np.stack([r @ flip for r in rots])))
    n_frames = (len(mats) - 1) * frames_per_segment
    ts = np.arange(n_frames) / frames_per_segment
    out = []
    for t, rot in zip(ts, slerp(ts).as_matrix(), strict=True):
        k = min(int(np.floor(t)), len(mats) - 2)
        a = t - k
        m = np.eye(4)
        m[:3, 3] = (1 - a) * mats[k][:3, 3] + a * mats[k + 1][:3, 3]
        m[:3, :3] = (rot @ flip) * ((1 - a) * scales[k] + a * scales[k + 1])
        out.append(m)
    return out


def yaw(to_world: np.ndarray, degrees: float) -> np.ndarray:
    """The camera turned about its own up axis by `degrees` (positive turns to the left)."""
    m = np.asarray(to_world, dtype=np.float64).copy()
    up = _rotation_part(m)[:, 1]
    from scipy.spatial.transform import Rotation

    r = Rotation.from_rotvec(np.radians(degrees) * up).as_matrix()
    m[:3, :3] = r @ m[:3, :3]
    return m


def backward_motion(depth: np.ndarray, cam: Camera, prev: Camera) -> np.ndarray:
    """Backward motion ``(H, W, 2)`` in pixels: pixel (x, y) of `cam` was at (x + mx, y + my) in `prev`.

    `depth` is the first-hit distance along each pixel's (unit) ray, as Mitsuba's ``aov`` depth gives it;
    0 (no hit) marks the environment, which moves as a point at infinity. Points behind the previous camera
    get zero motion.
    """
    d = np.asarray(depth, dtype=np.float64)
    if d.ndim == 3:
        d = d[..., 0]
    if d.shape != (cam.height, cam.width):
        raise ValueError(
            f"depth of shape {d.shape} does not match the camera's {cam.height}x{cam.width} film"
        )
    dirs = cam.pixel_directions()
    miss = ~(d > 0) | ~np.isfinite(d)
    points = np.where(miss[..., None], dirs, cam.origin + dirs * np.where(miss, 0, d)[..., None])
    prev_px, front = prev.project(points, at_infinity=miss)
    xs, ys = np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)
    motion = prev_px - np.stack([xs, ys], axis=-1)
    motion[~front] = 0
    return motion.astype(np.float32)
