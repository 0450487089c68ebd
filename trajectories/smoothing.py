"""A path of poses smoothed within tolerances: for a grid planner's output.

A path snapped to a grid (a raw ``nav_msgs/Path`` from a 2-D grid planner) steps along
the cells, its yaw in eighths of a turn: splines through every pose bend at every step,
and the time-optimal timing crawls through the bends. :func:`smooth_poses` fits the
positions (x and y with one smoothing weight) and the unwrapped yaw with cubic smoothing
splines (:func:`scipy.interpolate.make_smoothing_spline`: least squares plus ``lam``
times the integral of the squared second derivative, along the chord length, see
:data:`TURN_PARAMETER`) as smooth as the tolerances allow: the largest ``lam`` on a log
grid whose fit keeps every pose within ``position_tolerance`` [m] (Euclidean) and
``yaw_tolerance`` [rad] of the one given. Pinned poses (the ends, the poses of a turn in
place) keep exactly where they are.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.interpolate import make_smoothing_spline

from ._validation import FloatArray

#: The smoothing weight ``lam`` is searched over ``10**LOG_LAM`` (in the units of the path
#: parameter, metres: from interpolation to about a straight line for paths of metres to
#: kilometres), bisected this many times (its power to about 3e-4).
LOG_LAM = (-12.0, 8.0)
SEARCH_STEPS = 16

#: The weight of a pinned pose against 1 for the others (its fit is then set to it exactly).
PIN_WEIGHT = 1e8

#: The fewest poses a smoothing spline takes; shorter paths are left as they are.
MIN_POSES = 5

#: [m/rad] The fit's parameter is the chord length plus this much per radian turned: a
#: turn in place still moves it, and a grid path's yaw steps (an eighth of a turn every
#: few cells) barely do. Counted as the timing counts it (0.5 m/rad) they stretched the
#: parameter at each step, and the fit kept more of the steps: 400 poses snapped to a
#: 5 cm grid at 0.025 m and 0.4 rad, a 38.5 s lap against 22.8 s this way (22.0 s for the
#: path before it was snapped).
TURN_PARAMETER = 0.01


def smooth_poses(poses: FloatArray, position_tolerance: float, yaw_tolerance: float,
                 pinned: npt.NDArray[np.bool_]) -> FloatArray:
    """``poses`` (n, 3) (x, y and the unwrapped yaw; distinct consecutive poses) smoothed
    within ``position_tolerance`` [m] and ``yaw_tolerance`` [rad] (0: that part as given);
    ``pinned`` (n,) poses kept exactly. A copy."""
    smoothed = np.array(poses, dtype=float)
    if len(smoothed) < MIN_POSES:
        return smoothed
    steps = np.diff(smoothed, axis=0)
    parameter = np.concatenate(([0.0], np.cumsum(
        np.hypot(steps[:, 0], steps[:, 1]) + TURN_PARAMETER * np.abs(steps[:, 2]))))
    weights = np.where(pinned, PIN_WEIGHT, 1.0)
    if position_tolerance > 0.0:
        smoothed[:, :2] = _within(parameter, smoothed[:, :2], weights, position_tolerance)
    if yaw_tolerance > 0.0:
        smoothed[:, 2:] = _within(parameter, smoothed[:, 2:], weights, yaw_tolerance)
    smoothed[pinned] = poses[pinned]
    return smoothed


def _within(parameter: FloatArray, values: FloatArray, weights: FloatArray,
            tolerance: float) -> FloatArray:
    """The smoothest fit of ``values`` (n, k) on the search grid whose every row keeps
    within ``tolerance`` (Euclidean) of the one given; ``values`` if none does."""
    best, low, high = values, *LOG_LAM
    for _ in range(SEARCH_STEPS):
        middle = 0.5 * (low + high)
        # column by column: scipy takes a 2-D y only from 1.16 (this project: 1.10 on)
        fit = np.column_stack([make_smoothing_spline(parameter, column, w=weights,
                                                     lam=10.0**middle)(parameter)
                               for column in values.T])
        if float(np.sqrt(((fit - values) ** 2).sum(axis=1)).max()) <= tolerance:
            best, low = fit, middle
        else:
            high = middle
    return np.asarray(best, dtype=float)
