"""The plants ``mpc-bench perf`` closes its peers and compiled loops on (``--plants``).

``ideal``: the simulated robot does what it is told (:func:`mpc.sim.simulate`'s default),
from the reference's first pose. ``realistic``: the plant issue 37 measured the tick on as
a new user would, one that differs from the controller's model: :data:`mpc.sim.plant.
PLANT_PRESETS` ``"realistic"`` (ten RK4 substeps a tick, 30 ms motor lag, one tick of
command delay, 2 mm and 0.005 rad measurement noise, 3 % mean slip) from a start 0.28 m
off the reference (0.2 m in x and in y), its noise and slip seeded so that every
controller and every round of a run sees the same draws.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mpc.sim.plant import PLANT_PRESETS
from trajectories import Trajectory


@dataclass(frozen=True)
class PerfPlant:
    """A closed loop's plant and start.

    Attributes:
        preset: a :data:`~mpc.sim.plant.PLANT_PRESETS` name.
        start_offset: the true start pose minus the reference's at t = 0 (x [m], y [m],
            heading [rad], world frame).
        seed: seeds the plant's noise and slip (the same in every run).
    """

    preset: str
    start_offset: tuple[float, float, float]
    seed: int


#: The plants by ``--plants`` name.
PLANTS: dict[str, PerfPlant] = {
    "ideal": PerfPlant("ideal", (0.0, 0.0, 0.0), 0),
    "realistic": PerfPlant("realistic", (0.2, 0.2, 0.0), 37),
}


def simulate_options(name: str, trajectory: Trajectory) -> dict[str, Any]:
    """:func:`mpc.sim.simulate`'s keyword arguments for plant ``name`` (the ideal plant:
    none, so that its runs are what they were before plants were named)."""
    plant = PLANTS[name]
    if plant.preset == "ideal" and not any(plant.start_offset):
        return {}
    start = trajectory.sample(0.0).pose + np.asarray(plant.start_offset, dtype=float)
    return {"plant": plant.preset, "seed": plant.seed, "initial_pose": start}


def describe(name: str) -> str:
    """One line saying what plant ``name`` is."""
    plant = PLANTS[name]
    config = PLANT_PRESETS[plant.preset]
    offset = float(np.hypot(*plant.start_offset[:2]))
    faults = (f"{config.substeps} substeps, motor lag {config.motor_lag * 1e3:g} ms, "
              f"{config.delay_ticks} tick delay, noise {config.position_noise * 1e3:g} mm / "
              f"{config.heading_noise:g} rad, slip {config.slip:.0%}")
    start = (f"start {offset:.2f} m off the reference, seed {plant.seed}" if offset
             else "start on the reference")
    return f"{name} plant: {faults}; {start}"


__all__ = ["PLANTS", "PerfPlant", "describe", "simulate_options"]
