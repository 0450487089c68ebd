"""Reference timing: which stretch of the reference each tick's plan tracks.

:class:`ReferenceWindow` samples the trajectory at the stage times straight
into the tick's parameter views and evaluates the model's reference terms
there: the feedforward twist of stage ``k`` is the constant body twist that
drives the model exactly from reference pose ``k`` to ``k + 1`` in one tick
(the SE(2) logarithm divided by ``dt``), so a robot on the reference with
the feedforward stays on it. Time mode's windows are read from a grid sampled
ahead (:mod:`mpc.control.lookahead`) when the clock advances by whole ticks.

Two timing laws use it (both with one ``reset``):

- :class:`TimeIndexed` (``mode="time"``): stage ``k`` is the reference at
  ``t + offsets_k`` (plus the known delay; ``offsets`` the model's stage starts):
  strict time tracking.
- :class:`PathProgress` (``mode="path"``): the progress ``s_k`` along the
  reference (in seconds of the reference's own time) is planned with the
  motion. It never runs ahead of the reference's own timing
  (``s_k <= t + offsets_k``), never backwards, and at most ``max_progress_rate``
  times as fast as the reference (catching up). Where the reference is
  feasible the plan keeps ``s_k = t + k dt`` (time tracking); where it is
  not, the robot drives the path as fast as its wheels allow.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.control.lookahead import Lookahead, Strided
from mpc.model.layout import PathInput, TickInput
from mpc.model.tracking import TrackingModel, feedforward_twists, reference_directions
from trajectories import Trajectory, TrajectoryError, TrajectorySample

#: Path mode: half-width of the trust region on the progress around where the reference
#: was sampled [s of reference time]; the QP's first-order expansion of the path holds there.
PROGRESS_TRUST = 0.1

#: Path mode: with no plan to start from (after a reset or a failed solve), the first tick
#: re-samples the reference at the planned progress and solves again, up to this many
#: times, until the progress moves less than ``PROGRESS_SETTLED`` [s].
WARM_UP_ROUNDS = 6
PROGRESS_SETTLED = 1e-3


class ReferenceWindow:
    """Samples a trajectory over the horizon into a :class:`~mpc.model.layout.TickInput`
    (``terms``: the model's ``reference_terms`` or a compiled copy of them, for windows
    sampled on their own; windows read from the lookahead's grid take the same
    expressions evaluated over the whole grid, see :class:`_GridTerms`; ``grid=False``:
    every window sampled on its own, as path mode's are)."""

    def __init__(self, trajectory: Trajectory, model: TrackingModel, tick: TickInput,
                 terms: ca.Function | None = None, grid: bool = True) -> None:
        self.trajectory = trajectory
        self.tick = tick
        self.offsets = model.offsets
        self.lookahead = Lookahead(trajectory, model.offsets, float(model.durations[0]))
        self._velocities = np.zeros((model.horizon + 1, 3))
        self._evaluate = BufferedFunction(model.reference_terms if terms is None else terms,
                                          [tick.poses_ref, self._velocities],
                                          [tick.twists_ref, tick.directions])
        # the grid's terms, built now (not on the first tick: building their function for a
        # new grid shape takes milliseconds); path mode (grid=False) never reads the grid
        self._grid = (_GridTerms(self.lookahead, model.durations)
                      if grid and self.lookahead.gridded else None)
        #: Whole turns the last fill took off the reference's heading (its own value is
        #: ``poses_ref[0, 2] + 2 pi turns``).
        self.turns = 0

    def fill(self, time: float, heading: float, rate: float = 1.0) -> None:
        """The window at ``time + rate * offsets`` [s] (see :meth:`fill_at`; at rate 1 read
        from the :class:`~mpc.control.lookahead.Lookahead`)."""
        if rate != 1.0:
            self.fill_at(np.asarray(time + rate * self.offsets, dtype=float), heading)
            return
        ahead, grid = self.lookahead, self._grid
        first = None if grid is None else ahead.seek(time)
        if grid is None or first is None:
            self._write(*ahead.sample(time), heading)
            return
        # On the grid: the stages' terms were evaluated with the grid's (see _GridTerms).
        tick = self.tick
        ahead.stages.gather(ahead.pose, first, tick.poses_ref)
        self._unwrap(heading)
        grid.write(ahead, first, tick.twists_ref, tick.directions)

    def fill_at(self, times: FloatArray, heading: float) -> TrajectorySample:
        """Write the reference at the stage ``times`` (N+1,) [s] into the tick's views.

        The reference heading is shifted by a multiple of 2 pi so that its first
        value lies within pi of ``heading`` (the robot's), which makes the
        quadratic heading cost measure the wrapped error. Returns the sample.
        """
        sample = self.trajectory.sample(times)
        self._write(sample.pose, sample.velocity, heading)
        return sample

    def _write(self, pose: FloatArray, velocity: FloatArray, heading: float) -> None:
        """The reference's poses and velocities (N+1, 3) into the tick, and its terms."""
        self.tick.poses_ref[:] = pose
        self._unwrap(heading)
        self._velocities[:] = velocity
        self._evaluate()

    def _unwrap(self, heading: float) -> None:
        """The tick's reference heading moved by whole turns to within pi of ``heading``
        (:attr:`turns` of them)."""
        poses = self.tick.poses_ref
        turns = math.floor((poses[0, 2] - heading) / (2.0 * math.pi) + 0.5)
        self.turns = turns
        if turns:
            poses[:, 2] -= 2.0 * math.pi * turns


class _GridTerms:
    """The reference terms (feedforward and directions) of a lookahead's whole grid,
    evaluated once a fill: every pair of grid points as far apart as a stage's start and
    end (one tick for the first stage, ``dt`` for the rest), so that a tick on the grid
    gathers its stages' terms rather than calling the terms (one CasADi call fewer a
    tick; the heading's multiple of 2 pi does not change them)."""

    def __init__(self, ahead: Lookahead, durations: FloatArray) -> None:
        points, index = ahead.points, ahead.index
        starts, spans = index[:-1], np.diff(index)
        # The stages in kinds of one grid spacing and duration (the first; the rest): each
        # kind's stages (one run of them), where their starts are on the grid from the
        # window's first point, and the terms of every grid pair that far apart.
        self._kinds: list[tuple[slice, Strided, FloatArray]] = []
        pairs = sorted(set(zip(spans.tolist(), np.asarray(durations).tolist(), strict=True)))
        for span, duration in pairs:
            stages = np.flatnonzero((spans == span) & (durations == duration))
            if (np.diff(stages) != 1).any():  # durations are (tick, dt, ..., dt)
                raise RuntimeError("grid terms need each kind of stage in one run")
            self._kinds.append((slice(int(stages[0]), int(stages[-1]) + 1),
                                Strided(starts[stages]), np.zeros((points - span, 3))))
        self._pose, self._velocity = np.zeros((points, 3)), np.zeros((points, 3))
        self._directions = np.zeros((points, 2))
        self._evaluate = BufferedFunction(
            _grid_function(points, tuple(pairs)), [self._pose, self._velocity],
            [*(feedforward for _, _, feedforward in self._kinds), self._directions])
        self._stages = ahead.stages
        self._fill = -1  # the lookahead fill they are of

    def write(self, ahead: Lookahead, first: int, feedforward: FloatArray,
              directions: FloatArray) -> None:
        """The stages' feedforward (N, 3) and directions (N+1, 2) of the window starting at
        grid point ``first`` (the grid's terms evaluated anew after a fill)."""
        if self._fill != ahead.fills:
            self._pose[:] = ahead.pose
            self._velocity[:] = ahead.velocity
            self._evaluate()
            self._fill = ahead.fills
        for stages, starts, terms in self._kinds:
            starts.gather(terms, first, feedforward[stages])
        self._stages.gather(self._directions, first, directions)


@functools.lru_cache(maxsize=32)
def _grid_function(points: int, pairs: tuple[tuple[int, float], ...]) -> ca.Function:
    """The reference terms over a grid of ``points``: the feedforward of every pair of
    points ``span`` apart held ``duration`` seconds, for each ``(span, duration)`` of
    ``pairs``, then the directions at every point (built once per grid shape: a controller
    given a new trajectory, as ROS's set_plan does, reuses it)."""
    poses, velocities = ca.SX.sym("poses", 3, points), ca.SX.sym("velocities", 3, points)
    return ca.Function("grid_terms", [poses, velocities], [
        *(feedforward_twists(poses[:, :points - span], poses[:, span:],
                             ca.DM.ones(1, points - span) * duration)
          for span, duration in pairs),
        reference_directions(velocities)])


class TimeIndexed:
    """Stage ``k`` is the reference at the planning time plus ``k dt``: strict time tracking."""

    def __init__(self, window: ReferenceWindow) -> None:
        self.window = window

    def reset(self) -> None:
        """Nothing to forget."""

    def fill(self, t: float, t_plan: float, heading: float) -> float:
        """Fill the tick's reference for planning time ``t_plan``; return the reference time."""
        self.window.fill(t_plan, heading)
        return t_plan

    def solved(self, progress: FloatArray | None) -> None:
        """Nothing to carry."""

    def refine(self, progress: FloatArray | None, heading: float) -> bool:
        """Nothing to refine: the stage times are fixed."""
        return False


class PathProgress:
    """Path mode's progress: carried from tick to tick, planned by the solver.

    Args:
        window: the reference window.
        model: a path-mode model (its horizon, stage ``dt``, control ``tick`` and
            ``max_progress_rate``).
    """

    def __init__(self, window: ReferenceWindow, model: TrackingModel) -> None:
        path = window.tick.path
        if path is None:
            raise RuntimeError("PathProgress needs a path-mode TickInput")
        self.window, self.path = window, path
        self.durations, self.max_rate = model.durations, model.max_progress_rate
        self.tick = float(model.durations[0])
        self.offsets = window.offsets
        self._max_steps = self.max_rate * self.durations  # the progress's largest steps [s]
        self.reset()

    def reset(self) -> None:
        self._plan: FloatArray | None = None  # last planned progress s_0 .. s_N
        self._elapsed: float | None = None  # since the last plan [s], None after a jump
        self._previous_t: float | None = None
        self._rounds = 0  # refinements left this tick
        self._settled = False  # whether _plan came from a successful solve

    def fill(self, t: float, t_plan: float, heading: float) -> float:
        """Sample the reference at the guessed progress and set the progress bounds;
        return the progress ``s_0`` [s] (the reference time being tracked now)."""
        start = self._start(t, t_plan)
        self._t_plan = t_plan
        self._rounds = 0 if self._settled else WARM_UP_ROUNDS
        self._sample(self._guess(start, t_plan), heading)
        return start

    def refine(self, progress: FloatArray | None, heading: float) -> bool:
        """After a solve with no plan to start from: sample again at the planned progress
        and return True if the caller should solve again (False once it has settled, or
        where the trajectory cannot be sampled there: the solve stands)."""
        if progress is None or self._rounds <= 0:
            return False
        self._rounds -= 1
        if np.abs(progress - self.path.progress_guess).max() < PROGRESS_SETTLED:
            return False
        guess = np.minimum(np.maximum.accumulate(progress), self._t_plan + self.offsets)
        guess[0] = self.path.lower[0]
        try:
            self._sample(guess, heading)
        except TrajectoryError:  # (raised before anything is written) keep this solve
            return False
        return True

    def _sample(self, guess: FloatArray, heading: float) -> None:
        start = float(guess[0])
        sample = self.window.fill_at(guess, heading)
        path: PathInput = self.path
        path.progress_guess[:] = guess
        path.guess_progress[:] = guess
        path.path_rates[:] = sample.velocity
        path.path_curvatures[:] = sample.acceleration
        self._feedforward_rates(guess, sample)
        np.subtract(guess, PROGRESS_TRUST, out=path.lower)
        np.minimum(guess + PROGRESS_TRUST, self._t_plan + self.offsets, out=path.upper)
        path.lower[0] = path.upper[0] = start

    def solved(self, progress: FloatArray | None) -> None:
        """The plan's progress (or None after a failed solve: the guess is kept, and the
        next tick warms up again)."""
        self._settled = progress is not None
        self._plan = progress if progress is not None else self.path.progress_guess.copy()

    def _feedforward_rates(self, guess: FloatArray, sample: TrajectorySample) -> None:
        """Stage k's feedforward per unit progress rate: the sampled feedforward divided by
        the guess's rate (exact on the discrete model), or where the guess stands still,
        the reference's body twist per unit progress at the stage's start."""
        rates = (guess[1:] - guess[:-1]) / self.durations
        moving = rates > 1e-9
        out = self.path.feedforward_rates
        np.divide(self.window.tick.twists_ref, rates[:, None], out=out, where=moving[:, None])
        if not moving.all():
            theta = sample.pose[:-1, 2]
            c, s = np.cos(theta), np.sin(theta)
            world = sample.velocity[:-1]
            body = np.stack([c * world[:, 0] + s * world[:, 1],
                             c * world[:, 1] - s * world[:, 0], world[:, 2]], axis=1)
            out[~moving] = body[~moving]

    def _start(self, t: float, t_plan: float) -> float:
        """Where the last plan put the progress now; the planning time after a reset or a
        jump in ``t`` (backwards, or more than two ticks)."""
        elapsed = None if self._previous_t is None else t - self._previous_t
        self._previous_t = t
        self._elapsed = elapsed
        if self._plan is None or elapsed is None or not 0.0 < elapsed <= 2.0 * self.tick:
            self._elapsed = None
            return t_plan
        return min(float(np.interp(elapsed, self.offsets, self._plan)), t_plan)

    def _guess(self, start: float, t_plan: float) -> FloatArray:
        """Stage times to sample at: the last plan shifted to ``start`` (or on time), kept
        non-decreasing, within the rate limit and never ahead of ``t_plan + k dt``."""
        if self._plan is None or self._elapsed is None:
            steps = self.durations.copy()
        else:  # the plan read on from now, its last rate held past its end
            offsets, plan = self.offsets, self._plan
            times = self._elapsed + offsets
            moved = np.interp(times, offsets, plan)
            beyond = times > offsets[-1]
            last_rate = (plan[-1] - plan[-2]) / self.durations[-1]
            moved[beyond] = plan[-1] + last_rate * (times[beyond] - offsets[-1])
            steps = moved[1:] - moved[:-1]
        # (np.diff, np.clip and np.concatenate cost several times these ufuncs a tick)
        np.minimum(np.maximum(steps, 0.0, out=steps), self._max_steps, out=steps)
        guess = np.empty(steps.size + 1)
        guess[0] = 0.0
        np.cumsum(steps, out=guess[1:])
        guess += start
        return np.minimum(guess, t_plan + self.offsets, out=guess)
