"""The rigid-body map: chassis acceleration -> wheel torques -> contact forces, motor current.

Body frame (REP-103), body twist ``u = (vx, vy, omega)``. Newton-Euler in the rotating
body frame::

    M (du/dt + coriolis(u)) = wrench,   M = diag(m, m, I_z),
    coriolis(u) = (-omega vy, omega vx, 0)

(the body-frame acceleration of the centre of mass, the body origin, is
``du/dt + coriolis(u)``). Wheel ``i`` turns at ``W_i u`` (its velocity map, (d, 3)); by
virtual work its effort ``tau_i`` [N m] (a torque about its axle; for a swerve module
the torque *vector* along the module's ground velocity directions) pushes the body with
the wrench ``W_i^T tau_i``, so::

    wrench = sum_i W_i^T tau_i.

A robot with more wheel rows than three is over-actuated: the efforts are the
**minimum-norm** solution ``tau = pinv(W^T) wrench`` (no internal forces between wheels;
with identical wheels and motors, the least total squared current: the least copper
loss). A failed wheel (derated to 0) takes no share. The force the floor puts on wheel
``i``'s contact is ``W_i[:, :2]^T tau_i`` [N] (a Swedish wheel pushes along its rollers'
axis, ``|tau| / (r cos gamma)``; a swerve module along its torque vector, ``tau / r``;
the two actuators of a ball add up at its one contact). The drive torque a motor gives
is the effort along the wheel's rolling direction plus the wheel's own inertia
``J dw/dt`` (``J``: :attr:`~mpc.robots.drive.dynamics.RobotDynamics.wheel_inertia`); the
contact force does not include it.

Static normal loads: the weight ``m g`` shared so that the loads balance about the body
origin, the minimum-norm split (equal for the symmetric presets); load transfer from
acceleration (centre-of-mass height) is neglected.

This is the one force model of the project: the planner's rows, the clamp, the
command's contact forces (:attr:`~mpc.control.command.Command.contact_forces`) and the
motor plant (:mod:`mpc.sim.motor_plant`: its motors push with the plan's efforts, and
its contacts, one stiffness for all, share what no motor drives as the minimum-norm
split does) all use it: static loads, minimum-norm split, traction ``mu N`` per contact.
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray, IntArray, readonly
from mpc.errors import RobotError
from mpc.robots.drive.dynamics import GRAVITY, RobotDynamics


class DrivenRobot(Protocol):
    """What the force map reads of a robot (:class:`~mpc.robots.base.Robot` satisfies it)."""

    @property
    def name(self) -> str: ...
    @property
    def n_wheels(self) -> int: ...
    @property
    def wheel_dim(self) -> int: ...
    @property
    def wheel_blocks(self) -> FloatArray: ...  # (n, d, 3) [rad/s per twist unit]
    @property
    def wheel_positions(self) -> FloatArray: ...  # (n, 2) [m]
    @property
    def max_wheel_speed(self) -> FloatArray: ...  # (n,) [rad/s]
    @property
    def steered(self) -> bool: ...
    @property
    def dynamics(self) -> RobotDynamics | None: ...

    def drive_radii(self) -> FloatArray: ...  # (n,) [m]

#: [rad/s] below this wheel speed a steered wheel's drive direction is its steer angle.
AT_REST = 1e-6


def coriolis(twist: FloatArray) -> FloatArray:
    """``(-omega vy, omega vx, 0)`` for twist(s) (..., 3) [m/s^2]."""
    out = np.zeros(np.shape(twist))
    out[..., 0] = -twist[..., 2] * twist[..., 1]
    out[..., 1] = twist[..., 2] * twist[..., 0]
    return out


@dataclass(frozen=True, eq=False)
class ForceMap:
    """The rigid-body and motor constants of one robot with dynamics (module docstring).

    Attributes:
        mass_matrix: ``diag(m, m, I_z)`` (3, 3).
        distribution: wheel efforts per body wrench, ``pinv(W^T)`` (n, d, 3) [N m per N].
        effort_map: wheel efforts per body acceleration, ``distribution @ M`` (n, d, 3).
        drive_map: the drive torque map ``effort_map + J W`` (n, d, 3): torque per
            ``(u_k - u_{k-1}) / dt`` (the wheel's own inertia included).
        contact_of: each wheel's contact (n,); wheels at one point share it (a ball).
        contact_maps: contact force per body acceleration (c, 2, 3) [N per m/s^2].
        wheel_force_maps: each wheel's own contact force per body acceleration (n, 2, 3)
            [N per m/s^2], body frame: a swerve module's drive and lateral force together,
            a Swedish wheel's along its rollers' axis, each actuator of a ball its share
            (they sum to ``contact_maps`` at a shared contact).
        contact_directions: (c, 2) the unit direction of a contact whose force has one
            direction (a Swedish wheel's rollers), else zeros.
        normal_loads: static normal load of each contact (c,) [N].
        radii: wheel radii (n,) [m].
        resistance, kv, kt: one wheel's gearbox at the wheel [ohm, rad/s/V, N m/A].
        torque_limit: its largest torque at the wheel [N m] (current limit).
        count: motors per wheel.
    """

    robot: DrivenRobot
    dynamics: RobotDynamics
    mass_matrix: FloatArray
    distribution: FloatArray
    effort_map: FloatArray
    drive_map: FloatArray
    contact_of: IntArray
    contact_maps: FloatArray
    wheel_force_maps: FloatArray
    contact_directions: FloatArray
    normal_loads: FloatArray
    radii: FloatArray
    resistance: float
    kv: float
    kt: float
    torque_limit: float
    count: int

    @property
    def flat_blocks(self) -> FloatArray:
        """``W`` stacked (n d, 3)."""
        return self._flat["blocks"]

    @property
    def flat_effort(self) -> FloatArray:
        """``effort_map`` stacked (n d, 3)."""
        return self._flat["effort"]

    @property
    def flat_drive(self) -> FloatArray:
        """``drive_map`` stacked (n d, 3)."""
        return self._flat["drive"]

    @property
    def flat_contacts(self) -> FloatArray:
        """``contact_maps`` stacked (2 c, 3)."""
        return self._flat["contacts"]

    @functools.cached_property
    def wheel_maps(self) -> FloatArray:
        """(n, d, 9): each wheel's velocity block, ``drive_map`` and ``effort_map`` side by
        side (one product with a steered wheel's direction turns all three)."""
        return readonly(np.concatenate([self.robot.wheel_blocks, self.drive_map,
                                        self.effort_map], axis=2))

    @functools.cached_property
    def _flat(self) -> dict[str, FloatArray]:
        return {"blocks": readonly(self.robot.wheel_blocks.reshape(-1, 3)),
                "effort": readonly(self.effort_map.reshape(-1, 3)),
                "drive": readonly(self.drive_map.reshape(-1, 3)),
                "contacts": readonly(self.contact_maps.reshape(-1, 3))}

    @property
    def steered(self) -> bool:
        return bool(self.robot.steered)

    @property
    def n_contacts(self) -> int:
        return int(self.normal_loads.size)

    @property
    def friction_limits(self) -> FloatArray | None:
        """``mu N_c`` per contact [N], or None without a friction coefficient."""
        mu = self.dynamics.friction
        return None if mu is None else mu * self.normal_loads

    # ------------------------------------------------------------ maps
    def acceleration(self, last: FloatArray, twist: FloatArray, dt: float) -> FloatArray:
        """Body-frame acceleration of the step ``last -> twist`` over ``dt`` [s]: the change
        per second plus the Coriolis term at the step's middle (3,) [m/s^2, rad/s^2]."""
        return (twist - last) / dt + coriolis(0.5 * (twist + last))

    def efforts(self, acceleration: FloatArray) -> FloatArray:
        """Minimum-norm wheel efforts (n, d) [N m] for a body acceleration (3,)."""
        return self.effort_map @ acceleration

    def contact_forces(self, acceleration: FloatArray) -> FloatArray:
        """Floor-on-wheel contact forces (c, 2) [N] for a body acceleration (3,)."""
        return self.contact_maps @ acceleration

    def wheel_forces(self, acceleration: FloatArray) -> FloatArray:
        """Each wheel's floor-on-wheel force vector (n, 2) [N], body frame, for a body
        acceleration (3,) or (..., 3) (then (..., n, 2))."""
        return np.einsum("nkj,...j->...nk", self.wheel_force_maps, acceleration)

    def plan_forces(self, last: FloatArray, twists: FloatArray,
                    durations: FloatArray) -> FloatArray:
        """Each wheel's force vector (N, n, 2) [N], body frame, on every stage of a plan:
        twists (N, 3) held over ``durations`` (N,) [s], from the command before it
        ``last`` (3,); each stage's acceleration as :meth:`acceleration` gives it."""
        twists = np.asarray(twists, dtype=float)
        before = np.vstack([np.asarray(last, dtype=float)[None, :], twists[:-1]])
        rate = (twists - before) / np.asarray(durations, dtype=float)[:, None]
        return self.wheel_forces(rate + coriolis(0.5 * (twists + before)))

    def wrench(self, efforts: FloatArray) -> FloatArray:
        """Body wrench ``sum_i W_i^T tau_i`` (Fx, Fy, Mz) [N, N, N m] of efforts (n, d)."""
        return np.einsum("ndj,nd->j", self.robot.wheel_blocks, efforts)

    def drive_directions(self, twist: FloatArray, steer_angles: FloatArray | None) -> FloatArray:
        """Unit drive direction of each wheel (n, d): 1 for fixed wheels; for steered wheels
        the direction of ``W_i twist``, or the steer angle's where the wheel is at rest."""
        n, d = self.robot.n_wheels, self.robot.wheel_dim
        if d == 1:
            return np.ones((n, 1))
        velocity = self.robot.wheel_blocks @ twist
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        angles = np.zeros(n) if steer_angles is None else steer_angles
        rest = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        moving = speed > AT_REST
        return np.where(moving[:, None], velocity / np.maximum(speed, AT_REST)[:, None], rest)

    def drive_torques(self, last: FloatArray, twist: FloatArray, dt: float,
                      directions: FloatArray) -> FloatArray:
        """Drive torque of each wheel at the wheel (n,) [N m] for the step ``last -> twist``
        over ``dt``, along ``directions`` (n, d): efforts plus the wheel's inertia."""
        change = (twist - last) / dt
        torque = self.drive_map @ change + self.effort_map @ coriolis(0.5 * (twist + last))
        return np.einsum("nd,nd->n", torque, directions)

    def voltage(self, torque: FloatArray, speed: FloatArray) -> FloatArray:
        """Gearbox voltage [V] for wheel torque [N m] at wheel speed [rad/s]."""
        return speed / self.kv + self.resistance * torque / self.kt

    def motor_current(self, torque: FloatArray) -> FloatArray:
        """Each motor's current [A] for wheel torque [N m] (the gearbox's split ``count``
        ways)."""
        return torque / (self.kt * self.count)


_CACHE: weakref.WeakKeyDictionary[DrivenRobot, ForceMap] = weakref.WeakKeyDictionary()


def force_map(robot: DrivenRobot) -> ForceMap:
    """The :class:`ForceMap` of a robot with dynamics (built once per robot)."""
    cached = _CACHE.get(robot)
    if cached is None:
        cached = _build(robot)
        _CACHE[robot] = cached
    return cached


def _build(robot: DrivenRobot) -> ForceMap:
    dyn = robot.dynamics
    if dyn is None:
        raise RobotError(f"robot {robot.name!r} has no dynamics; attach them with "
                         "robot.with_dynamics(...)")
    radii = robot.drive_radii()
    blocks = robot.wheel_blocks  # (n, d, 3)
    n, d = blocks.shape[:2]
    mass = np.diag([dyn.mass, dyn.mass, dyn.yaw_inertia])
    active = np.repeat(robot.max_wheel_speed > 0.0, d)
    flat = blocks.reshape(-1, 3) * active[:, None]
    distribution = np.linalg.pinv(flat.T).reshape(n, d, 3)
    effort = distribution @ mass
    drive = effort + dyn.wheel_inertia * blocks
    wheel_forces = split_forces(blocks, mass, active)
    seen: dict[tuple[float, float], int] = {}  # contacts in order of first appearance
    contact_of = np.array([seen.setdefault((float(x), float(y)), len(seen))
                           for x, y in np.round(robot.wheel_positions, 9)], dtype=np.intp)
    contacts = len(seen)
    maps = np.zeros((contacts, 2, 3))
    directions = np.zeros((contacts, 2))
    for c in range(contacts):
        wheels = np.flatnonzero(contact_of == c)
        ground = blocks[wheels, :, :2].reshape(-1, 2)  # rows: force directions per effort
        maps[c] = np.einsum("rk,rj->kj", ground, effort[wheels].reshape(-1, 3))
        singular = np.linalg.svd(ground, compute_uv=False)
        if singular.size < 2 or singular[1] <= 1e-9 * singular[0]:
            directions[c] = ground[0] / np.linalg.norm(ground[0])
    loads = _normal_loads(robot, contact_of, contacts, dyn)
    wheel = dyn.wheel_motor
    return ForceMap(
        robot=robot, dynamics=dyn, mass_matrix=readonly(mass),
        distribution=readonly(distribution), effort_map=readonly(effort),
        drive_map=readonly(drive), contact_of=contact_of.astype(np.intp),
        contact_maps=readonly(maps), wheel_force_maps=readonly(wheel_forces),
        contact_directions=readonly(directions),
        normal_loads=readonly(loads), radii=readonly(radii), resistance=float(wheel.R),
        kv=float(wheel.kv), kt=float(wheel.kt), torque_limit=float(dyn.max_wheel_torque),
        count=int(wheel.count))


def split_forces(blocks: FloatArray, mass_matrix: FloatArray,
                 active: ArrayLike | None = None) -> FloatArray:
    """Each wheel's contact force per body acceleration (n, 2, 3) [N per m/s^2]: the
    minimum-norm efforts ``pinv(W^T) M`` (module docstring) pushed through each wheel's
    ground directions, ``W_i[:, :2]^T tau_i``. ``blocks``: the wheels' velocity maps
    ``W`` (n, d, 3) [rad/s per twist unit]; ``mass_matrix`` ``diag(m, m, I_z)``;
    ``active`` (n d,) which effort rows may carry load (default all). Needs no motors: a
    robot's rigid-body split for any mass."""
    n, d = blocks.shape[:2]
    flat = blocks.reshape(-1, 3)
    if active is not None:
        flat = flat * np.asarray(active, dtype=float)[:, None]
    effort = (np.linalg.pinv(flat.T) @ mass_matrix).reshape(n, d, 3)
    return np.einsum("ndk,ndj->nkj", blocks[:, :, :2], effort)


def _normal_loads(robot: DrivenRobot, contact_of: IntArray, contacts: int,
                  dyn: RobotDynamics) -> FloatArray:
    """Static loads that balance the weight about the body origin (minimum-norm split)."""
    points = np.zeros((contacts, 2))
    points[contact_of] = robot.wheel_positions
    balance = np.vstack([np.ones(contacts), points.T])  # (3, c)
    weight = dyn.mass * GRAVITY
    loads = np.linalg.pinv(balance) @ np.array([weight, 0.0, 0.0])
    residual = float(np.abs(balance @ loads - [weight, 0.0, 0.0]).max())
    if np.any(loads <= 0.0) or residual > 1e-6 * weight:
        raise RobotError(f"robot {robot.name!r}: its wheels cannot carry the weight balanced "
                         f"about the body origin (the centre of mass); loads {loads.round(3)} N")
    return loads


def apothem(sides: int) -> float:
    """The edge distance, over the disk's radius, of the polygon the QP takes for a disk:
    midway between the inscribed and the circumscribed one, ``(1 + cos(pi/sides)) / 2``
    (as the swerve speed polygon: closer to the disk on average; the clamp keeps the first
    command within the disk itself)."""
    return 0.5 * (1.0 + math.cos(math.pi / sides))
