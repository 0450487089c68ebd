"""The motor limits in the exact NLP: the rows of :mod:`mpc.robots.drive.motor_limits` as CasADi
expressions, with the Coriolis term, a steered wheel's drive direction ``v / |v|`` and the
battery's sag of the plan itself (no linearisation)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.base import Robot
from mpc.robots.drive.force_map import ForceMap, force_map

#: [rad/s] smoothing of a steered wheel's direction ``v / sqrt(|v|^2 + eps^2)``.
DIRECTION_SMOOTHING = 1e-3


def nlp_stage_limits(robot: Robot, twists: ca.SX, last: ca.SX, steer_angles: ca.SX | None,
                     change_times: FloatArray
                     ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
    """The NLP's limits: the robot's own (:meth:`Robot.nlp_stage_limits`) plus, with
    dynamics, the motor limits exactly (module docstring)."""
    values, lower, upper = robot.nlp_stage_limits(twists, last, steer_angles, change_times)
    if robot.dynamics is None:
        return values, lower, upper
    forces = force_map(robot)
    for k in range(twists.shape[1]):
        before = last if k == 0 else twists[:, k - 1]
        for value, low, high in _nlp_stage(forces, twists[:, k], before,
                                           float(change_times[k])):
            values.append(value)
            lower.append(low)
            upper.append(high)
    return values, lower, upper


def _nlp_stage(forces: ForceMap, now: ca.SX, before: ca.SX, dt: float
               ) -> list[tuple[ca.SX, FloatArray, FloatArray]]:
    """One change's motor limits, exactly: at its end (``now``'s speed and Coriolis term)
    and at its start (``before``'s)."""
    dyn = forces.dynamics
    keep, volts_kept = 1.0 - dyn.headroom, 1.0 - dyn.voltage_headroom
    volt = dyn.battery_voltage
    change = (now - before) / dt

    def coriolis_of(twist: ca.SX) -> ca.SX:
        return ca.vertcat(-twist[2] * twist[1], twist[2] * twist[0], 0)

    turns = (coriolis_of(now), coriolis_of(before))
    n = forces.robot.n_wheels
    speeds, torque = _drive_terms(forces, now, before, change, turns)
    voltage = tuple(speeds[side] / forces.kv
                    + forces.resistance * torque[side] / forces.kt for side in (0, 1))
    out: list[tuple[ca.SX, FloatArray, FloatArray]] = []
    if dyn.battery_resistance > 0.0:
        power = ca.dot(voltage[0], torque[0]) / forces.kt
        disc = ca.fmax(volt**2 - 4.0 * dyn.battery_resistance * power, 1e-6 * volt**2)
        bus = ca.fmin(0.5 * (volt + ca.sqrt(disc)), volt)
        allowed = volts_kept * ca.repmat(bus, n, 1)
        for value in voltage:
            out.append(((value - allowed) / volt, np.full(n, -np.inf), np.zeros(n)))
            out.append(((value + allowed) / volt, np.zeros(n), np.full(n, np.inf)))
    else:
        for value in voltage:
            out.append((value / volt, np.full(n, -volts_kept), np.full(n, volts_kept)))
    traction = forces.friction_limits
    for side in (0, 1):
        out.append((torque[side] / forces.torque_limit, np.full(n, -keep), np.full(n, keep)))
        if traction is None:
            continue
        accel = change + turns[side]
        for c in range(forces.n_contacts):
            contact = ca.DM(forces.contact_maps[c]) @ accel / traction[c]
            direction = forces.contact_directions[c]
            if np.any(direction):
                out.append((ca.dot(ca.DM(direction), contact), np.array([-keep]),
                            np.array([keep])))
            else:
                out.append((ca.sumsqr(contact), np.array([-np.inf]), np.array([keep**2])))
    return out


def _drive_terms(forces: ForceMap, now: ca.SX, before: ca.SX, change: ca.SX,
                 turns: tuple[ca.SX, ca.SX]) -> tuple[tuple[ca.SX, ca.SX], tuple[ca.SX, ca.SX]]:
    """Every wheel's drive speed and torque at the change's end and start: ((speeds at
    the end, at the start), (torques at the end, at the start)), each (n,); a steered
    wheel's along its (smoothed) drive direction at the end."""
    blocks = forces.robot.wheel_blocks
    speeds: tuple[list[ca.SX], list[ca.SX]] = ([], [])
    torques: tuple[list[ca.SX], list[ca.SX]] = ([], [])
    for i in range(blocks.shape[0]):
        block = ca.DM(blocks[i])
        velocities = (block @ now, block @ before)
        direction = None
        if blocks.shape[1] == 2:
            end = velocities[0]
            direction = end / ca.sqrt(ca.sumsqr(end) + DIRECTION_SMOOTHING**2)
        for side in (0, 1):
            effort = (ca.DM(forces.drive_map[i]) @ change
                      + ca.DM(forces.effort_map[i]) @ turns[side])
            if direction is None:
                speeds[side].append(velocities[side])
                torques[side].append(effort)
            else:
                speeds[side].append(ca.dot(direction, velocities[side]))
                torques[side].append(ca.dot(direction, effort))
    return ((ca.vertcat(*speeds[0]), ca.vertcat(*speeds[1])),
            (ca.vertcat(*torques[0]), ca.vertcat(*torques[1])))
