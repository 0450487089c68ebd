"""The battery bus under the power a plan draws: the scale ``B(P) / E`` of the voltage
rows' bound along the plan the solver starts from, its slope, and the power's gradient on
the twists (for the Newton step of :func:`mpc.robots.drive.motor_limits.update_stage_limits`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc.arrays import FloatArray
from mpc.robots.drive.force_map import ForceMap


@dataclass(frozen=True, eq=False)
class Sag:
    """The bus along the guess: ``scale = B(P) / E`` (N,), its slope ``B'(P) / E`` [per W]
    (N,), the power's gradient on ``u_k`` and ``u_{k-1}`` (N, 3) [W per twist unit], and
    every wheel's voltage at the end and the start of each change (N, n) [V]."""

    scale: FloatArray
    slope: FloatArray
    grad_now: FloatArray
    grad_before: FloatArray
    v_end: FloatArray
    v_start: FloatArray


def sag(forces: ForceMap, twists: FloatArray, previous: FloatArray, change_times: FloatArray,
         turn_end: FloatArray, turn_start: FloatArray, directions: FloatArray) -> Sag:
    """:class:`Sag` of the plan ``twists`` (power at each change's end: ``sum V T / kt``);
    steered wheels drive along the directions of their voltage rows (the first ``n`` motor
    rows of ``directions``)."""
    dyn = forces.dynamics
    robot = forces.robot
    n = robot.n_wheels
    times = change_times[:, None]
    change = (twists - previous) / times
    if robot.wheel_dim == 2:  # along each wheel's drive direction, as its rows have it
        e = directions[:, :n]  # (N, n, 2)
        maps = np.matmul(e.transpose(1, 0, 2), forces.wheel_maps).transpose(1, 0, 2)
        speed_map, drive_map, effort_map = maps[:, :, 0:3], maps[:, :, 3:6], maps[:, :, 6:9]

        def apply(maps: FloatArray, twist: FloatArray) -> FloatArray:
            return np.matmul(maps, twist[:, :, None])[:, :, 0]
    else:
        speed_map, drive_map = robot.wheel_blocks[:, 0], forces.drive_map[:, 0]
        effort_map = forces.effort_map[:, 0]

        def apply(maps: FloatArray, twist: FloatArray) -> FloatArray:
            return twist @ maps.T
    speed_end, speed_start = apply(speed_map, twists), apply(speed_map, previous)
    torque_base = apply(drive_map, change)
    torque_end = torque_base + apply(effort_map, turn_end)
    torque_start = torque_base + apply(effort_map, turn_start)
    v_end = forces.voltage(torque_end, speed_end)
    v_start = forces.voltage(torque_start, speed_start)
    power = (v_end * torque_end).sum(axis=1) / forces.kt
    volt, resistance = dyn.battery_voltage, dyn.battery_resistance
    disc = volt * volt - 4.0 * resistance * np.maximum(power, 0.0)
    scale = bus_voltages(volt, resistance, power) / volt
    slope = np.where((power > 0.0) & (disc > 1e-6 * volt * volt),
                     -resistance / np.sqrt(np.maximum(disc, 1e-12)), 0.0) / volt
    # dP = sum_j (T_j / kv ds_j + (V_j + R T_j / kt) dT_j) / kt, with ds = e W du_k and
    # dT = e D (du_k - du_{k-1}) / dt + e E J(ubar_k) du_k (J: the Coriolis Jacobian)
    through = (v_end + forces.resistance * torque_end / forces.kt) / forces.kt  # (N, n)
    by_speed = torque_end / (forces.kv * forces.kt)
    if robot.wheel_dim == 2:
        speed_grad = np.matmul(by_speed[:, None, :], speed_map)[:, 0]
        drive_grad = np.matmul(through[:, None, :], drive_map)[:, 0]
        effort_grad = np.matmul(through[:, None, :], effort_map)[:, 0]
    else:
        speed_grad, drive_grad = by_speed @ speed_map, through @ drive_map
        effort_grad = through @ effort_map
    omega, vx, vy = twists[:, 2], twists[:, 0], twists[:, 1]
    turned = np.stack([effort_grad[:, 1] * omega, -effort_grad[:, 0] * omega,
                       effort_grad[:, 1] * vx - effort_grad[:, 0] * vy], axis=1)
    grad_now = speed_grad + drive_grad / times + turned
    grad_before = -drive_grad / times
    return Sag(scale=scale, slope=slope, grad_now=grad_now, grad_before=grad_before,
                v_end=v_end, v_start=v_start)


def bus_voltages(open_circuit: float, resistance: float, power: FloatArray) -> FloatArray:
    """:func:`~mpc.robots.drive.dynamics.bus_voltage` for an array of powers [W]."""
    disc = np.maximum(open_circuit * open_circuit - 4.0 * resistance * np.maximum(power, 0.0),
                      0.0)
    return 0.5 * (open_circuit + np.sqrt(disc))
