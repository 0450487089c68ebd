"""The motor plant's physics: one implicit-Euler sub-step of the body, the wheels, their
motors and the floor contacts (the model is in :mod:`mpc.sim.motor_plant`'s docstring).

The motors and contacts that saturate (voltage clipped at the bus, current held at its
limit, a contact sliding at ``mu N``) are found by solving again with them saturated until
nothing changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc.arrays import BoolArray, FloatArray, IntArray
from mpc.robots.base import Robot
from mpc.robots.drive.force_map import ForceMap

#: [kg m^2] the plant's wheel inertia at least (massless wheels that slide with their current
#: held have no speed to settle at).
MIN_WHEEL_INERTIA = 1e-6


@dataclass(frozen=True)
class SubStep:
    """One sub-step's outcome: the voltages applied [V] and currents drawn [A] (n,), and
    what the wheel loops asked for against the limits."""

    voltage: FloatArray
    current: FloatArray
    voltage_violation: bool
    current_violation: bool
    slipped: bool
    voltage_ratio: float
    current_ratio: float
    traction_ratio: float


@dataclass(frozen=True, eq=False)
class SubStepModel:
    """What a sub-step holds fixed: the robot, its force map, the wheel loops' gain
    [V per rad/s], the motors' current limit [A], the contacts' creep (``slip_speed``
    [m/s], ``slip_ratio``) and strength ``mu N`` per wheel [N], and the implicit-Euler
    terms (mass matrix and wheel inertia over the sub-step, the back-EMF damping)."""

    robot: Robot
    forces: ForceMap
    velocity_gain: float
    current_limit: float
    slip_speed: float
    slip_ratio: float
    contact_strength: FloatArray
    mass_over_h: FloatArray
    inertia_over_h: float
    damping: float

    @classmethod
    def build(cls, robot: Robot, forces: ForceMap, velocity_gain: float, slip_speed: float,
              slip_ratio: float, substeps: int, dt: float) -> SubStepModel:
        """The model of ``robot`` (with dynamics) for ``substeps`` sub-steps a tick of ``dt``
        seconds."""
        dyn = forces.dynamics
        mu = 1.0 if dyn.friction is None else dyn.friction
        return cls(
            robot=robot, forces=forces, velocity_gain=velocity_gain,
            current_limit=forces.torque_limit / forces.kt,  # the gearbox's [A]
            slip_speed=slip_speed, slip_ratio=slip_ratio,
            contact_strength=(mu * forces.normal_loads)[forces.contact_of],
            mass_over_h=forces.mass_matrix * (substeps / dt),
            # a sliding wheel held at its current limit needs some inertia to spin up against
            inertia_over_h=max(dyn.wheel_inertia, MIN_WHEEL_INERTIA) * substeps / dt,
            damping=forces.kt / (forces.resistance * forces.kv))  # back-EMF [N m s/rad]

    def channels(self, steer_angles: FloatArray | None
                 ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Slip directions as rows on the twist (m, 3) [rad/s per twist unit], the wheel
        each drives (m,) (-1: a swerve module's lateral direction, no wheel) and the
        contact each belongs to (m,)."""
        robot, forces = self.robot, self.forces
        blocks = robot.wheel_blocks
        n = robot.n_wheels
        if robot.wheel_dim == 1:
            return blocks[:, 0, :], np.arange(n, dtype=float), forces.contact_of.astype(float)
        angles = steer_angles if steer_angles is not None else np.zeros(n)
        along = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        across = np.stack([-np.sin(angles), np.cos(angles)], axis=1)
        rows = np.concatenate([np.einsum("nd,ndj->nj", along, blocks),
                               np.einsum("nd,ndj->nj", across, blocks)])
        wheel = np.concatenate([np.arange(n), np.full(n, -1)]).astype(float)
        contact = np.concatenate([forces.contact_of, forces.contact_of]).astype(float)
        return rows, wheel, contact

    def step(self, state: tuple[FloatArray, FloatArray], steer_angles: FloatArray | None,
             ahead: FloatArray, bus: float) -> tuple[FloatArray, FloatArray, SubStep]:
        """One implicit-Euler sub-step from ``state`` (twist, wheel speeds ``w``): the twist
        and wheel speeds it reaches, and its :class:`SubStep`.

        Each wheel's loop asks for ``V = ahead - velocity_gain w`` (``w``: the speed the
        sub-step reaches; a motor controller's loop runs much faster than a sub-step);
        the controller clips it to the bus voltage, then holds the current at the limit;
        a contact past traction slides. Which wheels and contacts saturate is found by
        solving again with them saturated until nothing changes."""
        forces, n = self.forces, self.robot.n_wheels
        state_twist = state[0]
        rows, wheel, contact = self.channels(steer_angles)
        contact_index = contact.astype(int)
        stiffness = self._stiffness(rows, wheel, state_twist)
        actuated = wheel >= 0
        select = np.zeros((rows.shape[0], n))
        select[np.flatnonzero(actuated), wheel[actuated].astype(int)] = 1.0
        coriolis = forces.mass_matrix @ np.array([-state_twist[2] * state_twist[1],
                                                  state_twist[2] * state_twist[0], 0.0])
        # motor torque = drive - damping * w per wheel, by mode: 0 linear, 1 voltage
        # clipped at +-bus, 2 current held at +-limit
        mode = np.zeros(n, dtype=int)
        sign = np.zeros(n)
        fixed = np.zeros(rows.shape[0])  # efforts of sliding channels
        sliding = np.zeros(rows.shape[0], dtype=bool)
        limits = forces.friction_limits
        bus_bound = np.zeros(n, dtype=bool)  # held current needed more than the bus
        demand_asked = asked = np.zeros(n)  # what the loops asked for on the first pass
        traction = 0.0  # the largest contact force / (mu N) before any contact slid
        for attempt in range(2 * n + forces.n_contacts + 2):
            stick = np.where(sliding, 0.0, stiffness)
            twist, speeds = self._solve(state, coriolis, rows, stick, select, fixed, mode,
                                        sign, ahead, bus)
            demand = ahead - self.velocity_gain * speeds
            voltage = np.select([mode == 0, mode == 1], [demand, sign * bus],
                                speeds / forces.kv + sign * forces.resistance
                                * self.current_limit)
            current = (voltage - speeds / forces.kv) / forces.resistance
            if attempt == 0:  # what the loops ask for, before any saturation
                demand_asked = demand
                asked = (np.clip(demand, -bus, bus) - speeds / forces.kv) / forces.resistance
            changed = self._saturate_motors(mode, sign, demand, current, voltage, bus,
                                            bus_bound)
            if not changed and limits is not None:
                efforts = np.where(sliding, fixed, stick * (select @ speeds - rows @ twist))
                fixed, traction, changed = _slide_contacts(
                    rows, contact_index, efforts, fixed, sliding, limits, traction)
            if not changed:
                break
        return twist, speeds, SubStep(
            voltage=voltage, current=current,
            voltage_violation=bool(np.any(np.abs(demand_asked) > bus * (1.0 + 1e-9))),
            current_violation=bool(np.any(np.abs(asked) > self.current_limit * (1.0 + 1e-9))),
            slipped=bool(np.any(sliding)),
            voltage_ratio=float(np.abs(demand_asked).max()) / bus,
            current_ratio=float(np.abs(asked).max()) / self.current_limit,
            traction_ratio=traction)

    def _stiffness(self, rows: FloatArray, wheel: FloatArray, twist: FloatArray) -> FloatArray:
        """Each channel's contact stiffness [N per m/s, in wheel torque units]: one stiffness
        for every contact (the mean ``mu N`` over the creep at the contacts' mean ground
        speed, ``slip_speed + slip_ratio |v|``), so that the directions no motor drives
        (a swerve module's lateral one) share force as the planner's minimum-norm split
        does (:mod:`mpc.robots.drive.force_map`)."""
        planar = np.linalg.norm(rows[:, :2], axis=1)  # rad/s per m/s along the direction
        points = self.robot.wheel_positions
        ground = np.hypot(twist[0] - twist[2] * points[:, 1],
                          twist[1] + twist[2] * points[:, 0])
        creep = self.slip_speed + self.slip_ratio * float(ground.mean())
        stiffness: FloatArray = (float(self.contact_strength.mean()) / creep) / planar**2
        return stiffness

    def _solve(self, state: tuple[FloatArray, FloatArray], coriolis: FloatArray,
               rows: FloatArray, stick: FloatArray, select: FloatArray, fixed: FloatArray,
               mode: IntArray, sign: FloatArray, ahead: FloatArray,
               bus: float) -> tuple[FloatArray, FloatArray]:
        """The implicit-Euler system with the motors in ``mode`` and the sliding channels'
        efforts ``fixed``: the twist and wheel speeds the sub-step reaches."""
        forces = self.forces
        twist0, speeds0 = state
        k_r = forces.kt / forces.resistance
        drive = np.select([mode == 0, mode == 1],
                          [k_r * ahead, k_r * sign * bus], sign * forces.kt
                          * self.current_limit)
        damping = np.select([mode == 0, mode == 1],
                            [k_r * (self.velocity_gain + 1.0 / forces.kv), self.damping], 0.0)
        size = 3 + self.robot.n_wheels
        matrix = np.zeros((size, size))
        matrix[:3, :3] = self.mass_over_h + (rows.T * stick) @ rows
        matrix[:3, 3:] = -(rows.T * stick) @ select
        matrix[3:, :3] = matrix[:3, 3:].T
        matrix[3:, 3:] = (np.diag(self.inertia_over_h + damping)
                          + (select.T * stick) @ select)
        rhs = np.empty(size)
        rhs[:3] = self.mass_over_h @ twist0 - coriolis + rows.T @ fixed
        rhs[3:] = self.inertia_over_h * speeds0 + drive - select.T @ fixed
        solution = np.asarray(np.linalg.solve(matrix, rhs), dtype=np.float64)
        return solution[:3], solution[3:]

    def _saturate_motors(self, mode: IntArray, sign: FloatArray, demand: FloatArray,
                         current: FloatArray, voltage: FloatArray, bus: float,
                         bus_bound: BoolArray) -> bool:
        """Clip the loops that ask for more than the bus, hold the currents past the limit,
        and clip to the bus again a held current that needs more than it (a controller
        cannot apply more than its bus; ``bus_bound`` marks those, whose current may then
        pass the limit) (``mode``, ``sign`` and ``bus_bound`` in place); whether any
        changed."""
        changed = False
        clip = (mode == 0) & (np.abs(demand) > bus * (1.0 + 1e-12))
        if np.any(clip):
            mode[clip], sign[clip] = 1, np.sign(demand[clip])
            changed = True
        over = (mode == 2) & (np.abs(voltage) > bus * (1.0 + 1e-9))
        if np.any(over):
            mode[over], sign[over] = 1, np.sign(voltage[over])
            bus_bound |= over
            return True
        held = (mode < 2) & ~bus_bound & (np.abs(current) > self.current_limit * (1.0 + 1e-12))
        if np.any(held):
            mode[held], sign[held] = 2, np.sign(current[held])
            changed = True
        return changed


def _slide_contacts(rows: FloatArray, contact_index: IntArray, efforts: FloatArray,
                    fixed: FloatArray, sliding: BoolArray, limits: FloatArray,
                    traction: float) -> tuple[FloatArray, float, bool]:
    """Let the contacts past ``mu N`` (``limits``) slide at it: (the sliding channels'
    efforts, the largest traction ratio before any contact slid, whether any newly slid);
    ``sliding`` in place."""
    n_contacts = len(limits)  # one limit a contact
    force = np.zeros((n_contacts, 2))
    np.add.at(force, contact_index, rows[:, :2] * efforts[:, None])
    magnitude = np.hypot(force[:, 0], force[:, 1])
    slid = np.bincount(contact_index, weights=sliding.astype(float),
                       minlength=n_contacts) > 0
    if not np.any(slid):
        traction = max(traction, float((magnitude / limits).max()))
    over = (magnitude > limits * (1.0 + 1e-9)) & ~slid
    if not np.any(over):
        return fixed, traction, False
    scale = np.where(over, limits / np.maximum(magnitude, 1e-300), 1.0)
    newly = over[contact_index]
    fixed = np.where(newly, efforts * scale[contact_index], fixed)
    sliding |= newly
    return fixed, traction, True
