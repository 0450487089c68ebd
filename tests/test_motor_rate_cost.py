"""A motor robot's rate terms weigh what its motor rows bound: the body's acceleration
(Coriolis term included), and of the reference's own change only what friction allows.
Checked on the cost itself, against hand-derived plans: a body that turns at a constant
world velocity (no acceleration, so no force), and a reference that accelerates three
times faster than friction lets the robot."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mpc.model.tracking import TrackingModel
from mpc.model.weights import Weights
from mpc.robots import motor_preset

DT = 0.1
HORIZON = 4
#: Only the rate terms: the plans' poses are put on the reference's (no pose cost), and
#: the twist term is off.
RATE_ONLY = Weights(twist=0.0)


def rate_cost(robot, twists: np.ndarray, twists_ref: np.ndarray, last: np.ndarray) -> float:
    """The cost of ``twists`` (N, 3) against the reference twists (N, 3) from ``last``, the
    plan's poses on the reference's."""
    model = TrackingModel(robot, HORIZON, DT, RATE_ONLY)
    z, p = model.symbols()
    cost = ca.Function("cost", [z, p], [model.cost(z, p)])
    variables, parameters = model.layouts
    zv, pv = np.zeros(variables.size), np.zeros(parameters.size)
    variables.view(zv, "twists")[:] = twists
    parameters.view(pv, "twists_ref")[:] = twists_ref
    parameters.view(pv, "last_twist")[:] = last
    return float(cost(zv, pv))


def turning_body(speed: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """The body twists (N, 3) of a body turning at ``omega`` [rad/s] while it moves at
    ``speed`` [m/s] along world x (heading 0 now), and the last command (3,): its world
    velocity never changes, so its acceleration is zero."""
    times = np.concatenate(([0.0], DT * np.arange(1, HORIZON)))  # stage starts, tick = dt
    angles = omega * np.concatenate(([-DT], times))
    body = np.stack([speed * np.cos(angles), -speed * np.sin(angles),
                     np.full(angles.shape, omega)], axis=1)
    return body[1:], body[0]


def test_turning_the_body_meets_no_reference_change() -> None:
    """Reference: straight at 1.5 m/s, heading fixed. A plan that turns the body at
    0.8 rad/s at the same world velocity changes its body-frame twist by ``omega h v`` a
    stage but does not accelerate: the kinematic robot's rate terms charge it, the motor
    robot's (which weigh the acceleration, its Coriolis term linearised about the
    reference's twist: exact to second order in the angle turned, 0.24 rad here) less
    than 2 % of that."""
    motors = motor_preset("swerve")
    kinematic = motors.with_dynamics(None)
    speed, omega = 1.5, 0.8
    twists, last = turning_body(speed, omega)
    straight = np.tile([speed, 0.0, 0.0], (HORIZON, 1))
    charged = rate_cost(kinematic, twists, straight, last)
    weights = RATE_ONLY.rate + RATE_ONLY.module_rate * np.diag(kinematic.module_velocity_gram())
    by_hand = HORIZON * weights[1] * (omega * DT * speed) ** 2  # the body-frame vy change
    assert charged > 0.5 * by_hand
    assert rate_cost(motors, twists, straight, last) < 0.02 * charged


def test_reference_change_excused_up_to_friction() -> None:
    """Reference accelerating along x at three times what friction gives the motor robot.
    A plan accelerating at that limit pays (almost) nothing; a plan holding its speed pays
    for ``max_acceleration h`` a stage, not for the reference's whole change."""
    robot = motor_preset("swerve")
    dyn = robot.dynamics
    assert dyn is not None and dyn.max_acceleration is not None
    limit = dyn.max_acceleration
    assert math.isclose(limit, (1 - dyn.headroom) * dyn.friction * 9.81)
    starts = DT * np.arange(HORIZON + 1)
    last = np.array([0.5, 0.0, 0.0])
    reference = np.zeros((HORIZON, 3))
    reference[:, 0] = last[0] + 3.0 * limit * starts[1:]
    following = np.zeros((HORIZON, 3))
    following[:, 0] = last[0] + limit * starts[1:]
    holding = np.tile(last, (HORIZON, 1))
    gram = np.diag(robot.module_velocity_gram())
    weight_x = RATE_ONLY.rate[0] + RATE_ONLY.module_rate * gram[0]
    per_stage = weight_x * (limit * DT) ** 2
    assert rate_cost(robot, following, reference, last) < 0.02 * per_stage
    held = rate_cost(robot, holding, reference, last)
    assert math.isclose(held, HORIZON * per_stage, rel_tol=0.02)
    # without dynamics the whole change is excused: holding pays for 3x the limit
    kinematic = robot.with_dynamics(None)
    assert rate_cost(kinematic, holding, reference, last) > 8.0 * held
