"""The robot's outline on path plots: a padded convex hull of its wheels, placed at poses.

Plain numpy (no matplotlib): the figures draw what these functions return.
"""

from __future__ import annotations

import math

import numpy as np


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, (m, 2)."""
    unique = sorted({(float(x), float(y)) for x, y in points})
    if len(unique) < 3:
        return np.array(unique).reshape(-1, 2)

    def chain(ordered: list[tuple[float, float]]) -> list[tuple[float, float]]:
        hull: list[tuple[float, float]] = []
        for p in ordered:
            while len(hull) >= 2:
                (ox, oy), (ax, ay) = hull[-2], hull[-1]
                if (ax - ox) * (p[1] - oy) - (ay - oy) * (p[0] - ox) > 0:
                    break
                hull.pop()
            hull.append(p)
        return hull[:-1]

    return np.array(chain(unique) + chain(unique[::-1]))


def footprint(wheel_positions: object, fallback_half_size: float) -> np.ndarray:
    """Body-frame outline around the wheels [m], (m, 2): hull padded by 15% of the radius.

    Degenerate layouts (fewer than three non-collinear wheels) get a padded bounding
    box; a robot without wheel positions a square of ``fallback_half_size`` [m].
    """
    try:
        points = np.asarray(wheel_positions, dtype=float).reshape(-1, 2)
    except (TypeError, ValueError):
        points = np.empty((0, 2))
    points = points[np.all(np.isfinite(points), axis=1)]
    if len(points) == 0:
        s = fallback_half_size
        return np.array([[s, s], [-s, s], [-s, -s], [s, -s]])
    pad = max(0.15 * float(np.max(np.linalg.norm(points, axis=1))), 1e-3)
    hull = convex_hull(points)
    if len(hull) < 3:
        (x0, y0), (x1, y1) = points.min(axis=0) - pad, points.max(axis=0) + pad
        return np.array([[x1, y1], [x0, y1], [x0, y0], [x1, y0]])
    outward = hull - hull.mean(axis=0)
    norms = np.linalg.norm(outward, axis=1, keepdims=True)
    return hull + pad * outward / np.where(norms > 0, norms, 1.0)  # type: ignore[no-any-return]


def place(outline: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Body-frame outline moved to the world pose ``(x, y, theta)`` [m, m, rad]."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return outline @ np.array([[c, s], [-s, c]]) + pose[:2]  # type: ignore[no-any-return]
