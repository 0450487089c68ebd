"""Path mode's progress arithmetic as graphs: where the reference is sampled each tick and
what the samples become (the Python tick's :class:`~mpc.control.timing.PathProgress` and
:class:`~mpc.control.timing.ReferenceWindow`, written once more as CasADi expressions), so
that the compiled library, the virtual machine and the exported C library run the same
arithmetic and the caller only samples the trajectory at the times a graph gives.

- ``times``: the progress guess of a tick (``PathProgress._start`` and ``_guess``): the
  last plan's progress read on by the time elapsed since the last tick, kept
  non-decreasing, within the rate limit and never ahead of ``t + offsets``; on time
  (``t + k dt``) after a reset or a jump in ``t``.
- ``reference``: the samples at those times (poses, world velocities, accelerations) into
  the model's parameter vector and the progress bounds (``PathProgress._sample``: the
  heading unwrapped to within pi of the robot's, the feedforward and directions of
  :attr:`~mpc.model.tracking.TrackingModel.reference_terms`, the path rates and
  curvatures, the feedforward per unit progress rate, the trust region).
- ``refine``: after a solve with no plan to start from, whether the progress settled and
  the next round's times (``PathProgress.refine``).

The state between ticks (the last plan's progress, the last ``t``, the warm-up's rounds)
is ``tick.c``'s (and :class:`~mpc.tick.path_runner.VirtualPath`'s), not the graphs'.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.control.timing import PROGRESS_SETTLED, PROGRESS_TRUST
from mpc.model.tracking import TrackingModel

__all__ = ["progress_graphs"]


def progress_graphs(model: TrackingModel) -> tuple[ca.Function, ca.Function, ca.Function]:
    """``(times, reference, refine)`` of a path-mode ``model`` (module docstring):

    - ``times(t 1, previous 1, plan N+1, known 1) -> times N+1`` [s]: ``known`` 1 where
      a plan and the last tick's time ``previous`` are kept (else the guess is on time).
    - ``reference(pose 3, times N+1, t 1, poses 3 x N+1, velocities 3 x N+1,
      accelerations 3 x N+1) -> (reference P, bounds 2 x N+1)``: the parameter vector
      (its ``x0`` and ``last_twist`` zero: ``prepare`` writes them) and the progress's
      lower and upper bounds [s].
    - ``refine(progress N+1, times N+1, t 1) -> (settled 1, next N+1)``: 1 where the
      planned ``progress`` is within :data:`~mpc.control.timing.PROGRESS_SETTLED` of the
      ``times`` it was sampled at, and the times to sample at next round.
    """
    return _times(model), _reference(model), _refine(model)


def _interp(x: ca.SX, offsets: np.ndarray, values: ca.SX) -> ca.SX:
    """``np.interp(x, offsets, values)`` for a scalar ``x``: the segment's
    ``slope (x - o_j) + v_j``, the end values outside."""
    result = values[-1]
    for j in reversed(range(len(offsets) - 1)):
        slope = (values[j + 1] - values[j]) / float(offsets[j + 1] - offsets[j])
        result = ca.if_else(x < float(offsets[j + 1]),
                            slope * (x - float(offsets[j])) + values[j], result)
    return ca.if_else(x < float(offsets[0]), values[0], result)


def _times(model: TrackingModel) -> ca.Function:
    """``PathProgress._start`` and ``_guess`` (the caller's ``t`` is the planning time)."""
    n = model.horizon
    offsets = np.asarray(model.offsets, dtype=float)
    durations = np.asarray(model.durations, dtype=float)
    max_steps = model.max_progress_rate * durations
    tick = float(durations[0])
    t, previous, known = ca.SX.sym("t"), ca.SX.sym("previous"), ca.SX.sym("known")
    plan = ca.SX.sym("plan", n + 1)
    elapsed = t - previous
    valid = ca.logic_and(known > 0, ca.logic_and(elapsed > 0.0, elapsed <= 2.0 * tick))
    start = ca.if_else(valid, ca.fmin(_interp(elapsed, offsets, plan), t), t)
    # the plan read on from now, its last rate held past its end
    last_rate = (plan[n] - plan[n - 1]) / float(durations[-1])
    moved = []
    for offset in offsets:
        at = elapsed + float(offset)
        beyond = plan[n] + last_rate * (at - float(offsets[-1]))
        moved.append(ca.if_else(at > float(offsets[-1]), beyond, _interp(at, offsets, plan)))
    guess = [start]
    summed = ca.SX(0.0)
    for k in range(n):
        step = ca.if_else(valid, moved[k + 1] - moved[k], float(durations[k]))
        step = ca.fmin(ca.fmax(step, 0.0), float(max_steps[k]))
        summed = step if k == 0 else summed + step
        guess.append(summed + start)
    times = ca.vertcat(*[ca.fmin(value, t + float(offset))
                         for value, offset in zip(guess, offsets, strict=True)])
    return ca.Function("mpc_tick_progress_times", [t, previous, plan, known], [times],
                       ["t", "previous", "plan", "known"], ["times"], {"cse": True})


def _reference(model: TrackingModel) -> ca.Function:
    """``PathProgress._sample`` (with ``ReferenceWindow``'s unwrapped heading and terms)."""
    n = model.horizon
    parameters = model.layouts.parameters
    offsets = np.asarray(model.offsets, dtype=float)
    durations = np.asarray(model.durations, dtype=float)
    pose, t = ca.SX.sym("pose", 3), ca.SX.sym("t")
    times = ca.SX.sym("times", n + 1)
    poses = ca.SX.sym("poses", 3, n + 1)
    velocities = ca.SX.sym("velocities", 3, n + 1)
    accelerations = ca.SX.sym("accelerations", 3, n + 1)
    # the heading moved by whole turns to within pi of the robot's (ReferenceWindow._unwrap)
    turns = ca.floor((poses[2, 0] - pose[2]) / (2.0 * math.pi) + 0.5)
    unwrapped = ca.vertcat(poses[:2, :], poses[2, :] - 2.0 * math.pi * turns)
    feedforward, directions = model.reference_terms(unwrapped, velocities)
    # the feedforward per unit progress rate (PathProgress._feedforward_rates): divided by
    # the guess's rate where it moves, else the body twist per unit progress
    columns = []
    for k in range(n):
        rate = (times[k + 1] - times[k]) / float(durations[k])
        theta = poses[2, k]
        c, s = ca.cos(theta), ca.sin(theta)
        world = velocities[:, k]
        body = ca.vertcat(c * world[0] + s * world[1], c * world[1] - s * world[0], world[2])
        columns.append(ca.if_else(rate > 1e-9, feedforward[:, k] / rate, body))
    fields = {
        "x0": ca.SX.zeros(3), "poses_ref": unwrapped, "twists_ref": feedforward,
        "directions": directions, "last_twist": ca.SX.zeros(3), "progress_guess": times,
        "path_rates": velocities, "path_curvatures": accelerations,
        "feedforward_rates": ca.horzcat(*columns)}
    if set(fields) != set(parameters.fields):
        raise RuntimeError("the path reference graph does not fill the model's parameters: "
                           f"{sorted(set(parameters.fields) ^ set(fields))}")
    reference = ca.vertcat(*[ca.vec(fields[name]) for name in parameters.fields])
    upper = [ca.fmin(times[k] + PROGRESS_TRUST, t + float(offsets[k])) for k in range(n + 1)]
    lower = [times[k] - PROGRESS_TRUST for k in range(n + 1)]
    lower[0] = upper[0] = times[0]  # s_0 is where the robot is
    bounds = ca.vertcat(*[ca.vertcat(lo, up) for lo, up in zip(lower, upper, strict=True)])
    return ca.Function(
        "mpc_tick_progress_reference", [pose, times, t, poses, velocities, accelerations],
        [ca.densify(reference), ca.reshape(bounds, 2, n + 1)],
        ["pose", "times", "t", "poses", "velocities", "accelerations"],
        ["reference", "bounds"], {"cse": True})


def _refine(model: TrackingModel) -> ca.Function:
    """``PathProgress.refine``'s arithmetic (its rounds are the caller's)."""
    n = model.horizon
    offsets = np.asarray(model.offsets, dtype=float)
    progress, times, t = ca.SX.sym("progress", n + 1), ca.SX.sym("times", n + 1), ca.SX.sym("t")
    settled = ca.mmax(ca.fabs(progress - times)) < PROGRESS_SETTLED
    highest = [progress[0]]
    for k in range(1, n + 1):
        highest.append(ca.fmax(highest[-1], progress[k]))
    following = [ca.fmin(value, t + float(offset))
                 for value, offset in zip(highest, offsets, strict=True)]
    following[0] = times[0]  # (the progress bounds' s_0: where the robot is)
    return ca.Function("mpc_tick_progress_refine", [progress, times, t],
                       [settled, ca.vertcat(*following)], ["progress", "times", "t"],
                       ["settled", "next"], {"cse": True})
