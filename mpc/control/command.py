"""What the controller returns each tick."""

from __future__ import annotations

import enum
import functools
from collections.abc import Callable
from dataclasses import dataclass, field

from mpc.arrays import FloatArray
from mpc.robots.description.conventions import WheelConvention, wheel_convention


class Status(enum.Enum):
    """How this tick's command was obtained.

    ``SOLVED``: the solver converged (or, OSQP only, ran out of iterations
    with an iterate whose residual is small: ``Command.solver_status`` then
    says "maximum iterations reached"); its first twist, clamped into the
    wheel limits, is the command. The others are the fallbacks, in order:
    the shifted previous plan, the reference feedforward scaled into the
    limits, a stop ramp within the acceleration limits.
    """

    SOLVED = "solved"
    PREVIOUS_PLAN = "previous_plan"
    FEEDFORWARD = "feedforward"
    STOPPING = "stopping"


@dataclass(frozen=True, eq=False)
class Command:
    """One tick's command.

    Attributes:
        wheel_speeds: wheel speeds to send [rad/s], shape (n,); within the
            limits always. Swerve: signed, after the flip rule.
        twist: the commanded body twist (vx, vy, omega) [m/s, m/s, rad/s].
        steer_angles: swerve module steer angles [rad] in (-pi, pi] (with a steering range:
            absolute, inside it); casters: the angles
            the command turns them to by the end of the tick (measured + steer rate * dt);
            else None.
        predicted_poses: the plan's poses (N+1, 3) [m, m, rad].
        status: how the command was obtained (:class:`Status`).
        solver_status: the solver's own status text.
        solve_time: the solver's own time [s].
        tick_time: the whole ``step()`` [s].
        iterations: solver iterations.
        consecutive_failures: solver failures in a row, this tick included.
        clamped: whether the safety clamp had to change the twist.
        reference_time: the time on the reference the plan starts from [s]: ``t``
            (plus the known delay, and half a tick with ``command_ramp``) in time mode, the
            progress along the path in path mode.
        lag: how far ``reference_time`` trails ``t`` plus that lead [s] (0 in time mode;
            in path mode, > 0 while the robot is behind the reference's timing).
        steer_rates: casters (robots whose steer angles are states): the steer rates to
            send [rad/s], shape (n,), within their limits; else None.
        predicted_steer_angles: casters: the steer angles along the plan (N+1, n) [rad],
            from the measured ones (computed when first read, not in the tick: it is no
            command); else None.
        steer_prediction: what computes ``predicted_steer_angles`` (casters), or None.
        wheel_forces: robots with dynamics, the first step's planned drive force of each
            wheel at the floor [N] (n,), signed like ``wheel_speeds``; else None.
        motor_torques: the torque of each of a wheel's motors at its shaft [N m] (n,)
            (wheel inertia included); else None.
        motor_currents: the current of each of a wheel's motors [A] (n,), what a
            torque-current mode takes; else None.
        contact_forces: robots with dynamics, the first step's planned floor-on-wheel
            force vector of each wheel in the body frame [N] (n, 2): a swerve module's
            drive and lateral force together, a Swedish wheel's along its rollers' axis
            (each actuator of a ball its share); with their moments they sum to the
            step's ``M a`` (:meth:`~mpc.robots.drive.force_map.ForceMap.wheel_forces`);
            else None.
    """

    wheel_speeds: FloatArray
    twist: FloatArray
    steer_angles: FloatArray | None
    predicted_poses: FloatArray
    status: Status
    solver_status: str
    solve_time: float
    tick_time: float
    iterations: int
    consecutive_failures: int
    clamped: bool
    reference_time: float
    lag: float = 0.0
    steer_rates: FloatArray | None = None
    wheel_forces: FloatArray | None = None
    motor_torques: FloatArray | None = None
    motor_currents: FloatArray | None = None
    contact_forces: FloatArray | None = None
    steer_prediction: Callable[[], FloatArray] | None = field(default=None, repr=False)

    @functools.cached_property
    def predicted_steer_angles(self) -> FloatArray | None:
        """Casters: the steer angles along the plan (N+1, n) [rad], from the measured ones
        (computed on first reading); else None."""
        return None if self.steer_prediction is None else self.steer_prediction()

    def wheel_speeds_as(self, convention: str | WheelConvention,
                        wheel_radius: float | None = None) -> FloatArray:
        """``wheel_speeds`` in another source's wheel order, signs and unit: a name of
        :data:`mpc.robots.CONVENTIONS` (``"jetauto"``: motors 1-4 in rev/s, right side
        negated) or a :class:`~mpc.robots.WheelConvention`. Conventions in rim speed [m/s]
        need ``wheel_radius`` [m]."""
        return wheel_convention(convention).from_ours(self.wheel_speeds, wheel_radius)
