"""Baselines a user would otherwise pick: feedforward plus P pose feedback.

The twist is the reference's body twist plus proportional feedback on the
pose error (world frame, heading wrapped), mapped to wheels in one of two
ways:

- ``"clip"``: each wheel's velocity is clipped to its speed limit and its
  change to its acceleration limit, independently (what a motor driver or a
  per-wheel slew-rate limiter does). Cheap, but the wheels no longer agree
  on one rigid-body motion, so the robot moves in another direction.
- ``"desaturate"``: the whole twist is scaled uniformly into the speed
  limits (WPILib's ``desaturateWheelSpeeds``) and then towards the last
  command into the acceleration limits. Keeps the direction, loses speed.

Casters (robots whose steer angles are states) are mapped at the *measured* steer
angles, as the open-source powered-caster drivers do: ``"clip"`` clips every drive
rate and every steer rate to its limit independently (the joints then disagree on
one rigid motion: the robot moves by their least-squares twist, the rest is slip);
``"desaturate"`` scales the twist uniformly until every joint rate is within its
limit (and steps from the last command within the drive acceleration limit).

Neither looks ahead; that is the difference from the MPC.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mpc.angles import wrap_angle
from mpc.arrays import FloatArray
from mpc.control.clamp import clamp_command
from mpc.control.command import Command, Status
from mpc.control.measurements import check_steer_angles
from mpc.errors import ControllerError
from mpc.robots.base import Robot
from mpc.validation import is_finite_number, shown
from trajectories import Trajectory

#: Valid ``saturation=`` names.
SATURATIONS: tuple[str, ...] = ("clip", "desaturate")


#: Baselines of wheel types whose joint states each tick takes besides the pose (sliders),
#: by :attr:`~mpc.robots.Robot.kind`: ``FeedforwardPController(robot, ...)`` builds one of
#: these for such a robot (same arguments). Registered by their modules.
_JOINT_BASELINES: dict[str, type] = {}


def register_baseline(kind: str, baseline: type) -> None:
    """Make ``FeedforwardPController(robot, ...)`` of a robot of ``kind`` a ``baseline``
    taking the same arguments."""
    _JOINT_BASELINES[kind] = baseline


class FeedforwardPController:
    """Reference feedforward plus proportional pose feedback.

    ``twist = R(theta)^T (v_ref + K_p (p_ref - p)), omega = omega_ref + K_theta e_theta``

    Args:
        robot: the drive layout and its limits.
        trajectory: the reference.
        dt: control tick [s].
        gains: (K_xy, K_theta) [1/s]; default (4, 4), about a tenth of the
            tick rate, which tracks fast without ringing under a tick of delay.
        saturation: ``"clip"`` or ``"desaturate"`` (see the module docstring).
    """

    def __new__(cls, *args: Any, **kwargs: Any) -> Any:
        robot = args[0] if args else kwargs.get("robot")
        chosen = _JOINT_BASELINES.get(getattr(robot, "kind", "")) if cls is FeedforwardPController \
            else None
        if chosen is not None:
            return chosen(*args, **kwargs)
        return super().__new__(cls)

    def __init__(
        self,
        robot: Robot,
        trajectory: Trajectory,
        dt: float = 0.05,
        gains: tuple[float, float] = (4.0, 4.0),
        saturation: str = "desaturate",
    ) -> None:
        if not isinstance(robot, Robot):
            raise ControllerError(f"robot must be an mpc.robots.Robot, got {type(robot).__name__}")
        if not isinstance(trajectory, Trajectory):
            raise ControllerError(
                f"trajectory must be a trajectories.Trajectory, got {type(trajectory).__name__}"
            )
        if not is_finite_number(dt) or dt <= 0:
            raise ControllerError(f"dt must be a finite number of seconds > 0, got {shown(dt)}")
        if saturation not in SATURATIONS:
            raise ControllerError(
                f"unknown saturation {shown(saturation)}; expected one of {list(SATURATIONS)}"
            )
        gain = np.asarray(gains, dtype=float)
        if gain.shape != (2,) or not np.all(np.isfinite(gain)) or np.any(gain < 0):
            raise ControllerError(f"gains must be two finite numbers >= 0, got {shown(gains)}")
        self.robot = robot
        self.trajectory = trajectory
        self.dt = float(dt)
        self.gains = gain
        self.saturation = saturation
        self.reset()

    def reset(self) -> None:
        """The robot is at rest; steered wheels point forward."""
        self._last = np.zeros(3)
        self._last_wheels = np.zeros((self.robot.n_wheels, self.robot.wheel_dim))
        self._steer = self.robot.initial_steer_angles()

    def step(self, pose: ArrayLike, t: float, steer_angles: ArrayLike | None = None) -> Command:
        """The command for measured ``pose`` (x, y, theta) at time ``t`` [s]; casters need
        their measured ``steer_angles`` [rad] (n,)."""
        start = time.perf_counter()
        x = np.asarray(pose, dtype=float)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise ControllerError(f"pose must be a finite (3,) pose, got {shown(pose)}")
        if not is_finite_number(t):
            raise ControllerError(f"t must be a finite time in seconds, got {shown(t)}")
        # Feedforward at mid-tick: the command is held over [t, t + dt].
        reference = self.trajectory.sample(t)
        ahead = self.trajectory.sample(t + 0.5 * self.dt)
        error = reference.pose - x
        error[2] = float(wrap_angle(error[2]))
        world = ahead.velocity[:2] + self.gains[0] * error[:2]
        c, s = math.cos(x[2]), math.sin(x[2])
        target = np.array([c * world[0] + s * world[1], -s * world[0] + c * world[1],
                           ahead.velocity[2] + self.gains[1] * error[2]])
        measured = check_steer_angles(self.robot, steer_angles)  # casters' angles, else None
        if measured is not None:
            return self._joint_step(target, measured, reference.pose, float(t), start)
        if self.saturation == "desaturate":
            twist, clamped = clamp_command(self.robot, self.robot.desaturate(target),
                                           self._last, self.dt)
            clamped = clamped or not np.allclose(twist, target)
            wheels = self.robot.wheel_velocities(twist)
        else:
            wheels = self._clip(self.robot.wheel_velocities(target))
            twist = self.robot.twist_from_velocities(wheels)
            clamped = not np.allclose(wheels, self.robot.wheel_velocities(target))
        self._last, self._last_wheels = twist, wheels
        speeds, self._steer = self.robot.commands_from_velocities(wheels, self._steer)
        return Command(
            wheel_speeds=speeds, twist=twist, steer_angles=self._steer,
            predicted_poses=reference.pose[None, :], status=Status.SOLVED,
            solver_status="none", solve_time=0.0, tick_time=time.perf_counter() - start,
            iterations=0, consecutive_failures=0, clamped=clamped, reference_time=float(t),
        )

    def _joint_step(self, target: FloatArray, angles: FloatArray, reference: FloatArray,
                    t: float, start: float) -> Command:
        """Casters: joint rates at the measured angles, clipped per joint or scaled."""
        robot = self.robot
        if self.saturation == "desaturate":
            drive, steer = robot.joint_rates(target, angles)
            magnitude = np.concatenate([np.abs(drive), np.abs(steer)])
            bound = np.concatenate([robot.max_wheel_speed, robot.max_steer_rates
                                    if robot.max_steer_rates is not None else np.abs(steer)])
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(magnitude > 1e-12, bound / magnitude, np.inf)
            scaled = target * min(1.0, float(ratio.min()))
            twist, _ = clamp_command(robot, scaled, self._last, self.dt, angles)
            drive, steer = robot.joint_rates(twist, angles)
        else:
            drive, steer = robot.joint_rates(target, angles)
            limit = robot.max_wheel_speed
            drive = np.clip(drive, -limit, limit)
            accel = robot.max_wheel_accel
            if accel is not None:
                previous = self._last_wheels[:, 0]
                drive = np.clip(drive, previous - accel * self.dt, previous + accel * self.dt)
            if robot.max_steer_rates is not None:
                steer = np.clip(steer, -robot.max_steer_rates, robot.max_steer_rates)
            twist = robot.joint_twist(drive, steer, angles)
        clamped = not np.allclose(twist, target)
        self._last = twist
        self._last_wheels = np.zeros_like(self._last_wheels)
        self._last_wheels[:, 0] = drive
        return Command(
            wheel_speeds=drive, twist=twist, steer_angles=angles + steer * self.dt,
            predicted_poses=reference[None, :], status=Status.SOLVED, solver_status="none",
            solve_time=0.0, tick_time=time.perf_counter() - start, iterations=0,
            consecutive_failures=0, clamped=clamped, reference_time=t, steer_rates=steer)

    def _clip(self, wheels: FloatArray) -> FloatArray:
        """Per-wheel: speed into its limit, change into its acceleration limit."""
        limit = self.robot.max_wheel_speed[:, None]
        wheels = wheels * np.minimum(1.0, limit / np.maximum(_norm(wheels), 1e-300))
        accel = self.robot.max_wheel_accel
        if accel is not None:
            change = wheels - self._last_wheels
            bound = accel[:, None] * self.dt
            wheels = self._last_wheels + change * np.minimum(
                1.0, bound / np.maximum(_norm(change), 1e-300))
        return wheels


def _norm(vectors: FloatArray) -> FloatArray:
    return np.linalg.norm(vectors, axis=1, keepdims=True)
