"""Path mode's progress graphs (:mod:`mpc.tick.progress`) against the Python tick's
:class:`~mpc.control.timing.PathProgress` on seeded random plans: the times to sample at
(the plan read on, a plan that stands still, one read past its end, a jump in ``t``), the
parameter vector and bounds made of the samples (a heading whole turns away, progress that
stands still), and the warm-up's test and next times."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from mpc import Controller
from mpc.control.timing import PathProgress, ReferenceWindow
from mpc.model.layout import TickInput
from mpc.model.tracking import TrackingModel
from mpc.robots import preset
from mpc.tick.progress import progress_graphs
from trajectories import FigureEight

HORIZON = 6
DT = 0.05


Setup = tuple[TrackingModel, tuple[ca.Function, ca.Function, ca.Function], FigureEight]


@pytest.fixture(scope="module")
def setup() -> Setup:
    trajectory = FigureEight(1.0, 8.0, heading="tangent")
    model = Controller(preset("mecanum"), trajectory, horizon=HORIZON, dt=DT,
                       mode="path").model
    return model, progress_graphs(model), trajectory


def _python(model: TrackingModel, trajectory: FigureEight
            ) -> tuple[PathProgress, TickInput]:
    tick = TickInput(model.layouts)
    window = ReferenceWindow(trajectory, model, tick, grid=False)
    return PathProgress(window, model), tick


def _plan(rng: np.random.Generator, start: float) -> np.ndarray:
    """A non-decreasing progress plan, some of its steps standing still."""
    steps = rng.uniform(0.0, 0.08, HORIZON) * (rng.uniform(size=HORIZON) > 0.3)
    return start + np.concatenate([[0.0], np.cumsum(steps)])


def test_the_graphs_give_path_progress_numbers(setup: Setup) -> None:
    model, (times_graph, reference_graph, refine_graph), trajectory = setup
    rng = np.random.default_rng(37)
    standing = known_cases = 0
    for case in range(300):
        timing, tick = _python(model, trajectory)
        path = tick.path
        assert path is not None
        t = float(rng.uniform(0.5, 6.0))
        previous = t - float(rng.choice([DT, 0.5 * DT, 2 * DT, 3 * DT, -DT, 0.0]))
        plan = _plan(rng, previous - float(rng.uniform(0.0, 0.3)))
        known = case % 5 != 0
        if known:  # (a fresh PathProgress: no plan, no previous tick)
            timing._plan, timing._previous_t = plan.copy(), previous
            known_cases += 1
        heading = float(rng.uniform(-20.0, 20.0))  # whole turns from the reference's
        timing._settled = False
        start = timing.fill(t, t, heading)
        times = np.array(times_graph(t, previous, plan, 1.0 if known else 0.0)).ravel()
        np.testing.assert_allclose(times, path.progress_guess, rtol=0, atol=1e-12)
        assert times[0] == pytest.approx(start, abs=1e-12)
        sample = trajectory.sample(times)
        pose = np.array([0.0, 0.0, heading])
        reference, bounds = (np.array(x) for x in reference_graph(
            pose, times, t, sample.pose.T, sample.velocity.T, sample.acceleration.T))
        np.testing.assert_allclose(reference.ravel(), tick.parameters, rtol=0, atol=1e-9)
        np.testing.assert_allclose(bounds[0], path.lower, rtol=0, atol=1e-12)
        np.testing.assert_allclose(bounds[1], path.upper, rtol=0, atol=1e-12)
        standing += int(np.any(np.diff(times) <= 1e-9 * DT))
        # the warm-up: a planned progress near or far from where it was sampled
        progress = times + rng.normal(0.0, float(rng.choice([1e-4, 3e-2])), times.size)
        guess = path.progress_guess.copy()
        again = timing.refine(progress, heading)
        settled, following = (np.array(x).ravel() for x in refine_graph(progress, guess, t))
        assert bool(settled[0]) is not again
        if again:
            np.testing.assert_allclose(following, path.progress_guess, rtol=0,
                                       atol=1e-12)
    assert standing >= 20 and known_cases >= 200  # (both branches met)


def test_a_heading_whole_turns_away_is_unwrapped(setup: Setup) -> None:
    model, (times_graph, reference_graph, _), trajectory = setup
    times = np.array(times_graph(1.0, 0.0, np.zeros(HORIZON + 1), 0.0)).ravel()
    sample = trajectory.sample(times)
    turned = float(sample.pose[0, 2]) + 6.0 * math.pi + 0.1
    reference, _ = reference_graph(np.array([0.0, 0.0, turned]), times, 1.0,
                                   sample.pose.T, sample.velocity.T, sample.acceleration.T)
    poses = model.layouts.parameters.view(np.array(reference).ravel(), "poses_ref")
    np.testing.assert_allclose(poses[:, 2], sample.pose[:, 2] + 6.0 * math.pi, atol=1e-12)
