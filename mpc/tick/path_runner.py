"""Path mode's tick in three calls, on either runner (:mod:`mpc.tick.runners`): the times at
which to sample the reference, the tick with those samples, and the warm-up's next round
(``tick.c``'s ``mpc_tick_path_times``, ``mpc_tick_path_step``, ``mpc_tick_path_again``).
The arithmetic is the progress graphs' (:mod:`mpc.tick.progress`); the state between ticks
(the last plan's progress, the last tick's time, the warm-up's rounds) is ``tick.c``'s in
the compiled library and :class:`VirtualPath`'s on the virtual machine, kept by the same
rules.
"""

from __future__ import annotations

import ctypes
from typing import Protocol

import numpy as np

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.control.timing import WARM_UP_ROUNDS
from mpc.tick.path import PathGraphs
from mpc.tick.runners import STATUS, NativeTick, TickRunner, VirtualTick, output_size

__all__ = ["NativePath", "PathRunner", "VirtualPath", "path_runner"]


class PathRunner(Protocol):
    """Path mode's tick (module docstring)."""

    def reset(self) -> None:
        """Forget the progress (with the runner's own reset)."""

    def times(self, t: float) -> FloatArray:
        """The times [s] (N+1,) at which to sample the reference for the tick at ``t``."""

    def step(self, pose: FloatArray, poses: FloatArray, velocities: FloatArray,
             accelerations: FloatArray) -> FloatArray:
        """The tick (or a warm-up round) on the reference sampled at the last times given
        (each (N+1, 3), world frame; NaN where it could not be sampled): the output
        array."""

    def again(self) -> FloatArray | None:
        """The times of another warm-up round, or None (settled, no rounds left, or the
        last step did not solve)."""


def path_runner(runner: TickRunner, graphs: PathGraphs) -> PathRunner:
    """The path-mode calls of ``runner``."""
    if isinstance(runner, NativeTick):
        return NativePath(runner, graphs)
    assert isinstance(runner, VirtualTick)
    return VirtualPath(runner, graphs)


class NativePath:
    """The compiled library's path-mode calls, through ctypes."""

    def __init__(self, runner: NativeTick, graphs: PathGraphs) -> None:
        lib, pointer = runner._lib, ctypes.c_void_p
        lib.mpc_tick_path_times.argtypes = [pointer, ctypes.c_double, pointer]
        lib.mpc_tick_path_step.argtypes = [pointer] * 6
        lib.mpc_tick_path_step.restype = ctypes.c_int
        lib.mpc_tick_path_again.argtypes = [pointer, pointer]
        lib.mpc_tick_path_again.restype = ctypes.c_int
        self._lib, self._runner = lib, runner
        self._times = np.zeros(graphs.progress)
        self._pose = np.zeros(3)

    def reset(self) -> None:
        """(``mpc_tick_reset`` forgets the progress.)"""

    def times(self, t: float) -> FloatArray:
        self._lib.mpc_tick_path_times(self._runner._handle, float(t), self._times.ctypes.data)
        return self._times.copy()

    def step(self, pose: FloatArray, poses: FloatArray, velocities: FloatArray,
             accelerations: FloatArray) -> FloatArray:
        self._pose[:] = pose
        arrays = [np.ascontiguousarray(values, dtype=float)
                  for values in (poses, velocities, accelerations)]
        self._lib.mpc_tick_path_step(self._runner._handle, self._pose.ctypes.data,
                                     *(values.ctypes.data for values in arrays),
                                     self._runner._out_pointer)
        return self._runner._out

    def again(self) -> FloatArray | None:
        if not self._lib.mpc_tick_path_again(self._runner._handle, self._times.ctypes.data):
            return None
        return self._times.copy()


class VirtualPath:
    """The same calls on the virtual machine: the progress graphs evaluated by CasADi
    around :class:`~mpc.tick.runners.VirtualTick` (``tick.c``'s rules, line for line)."""

    def __init__(self, runner: VirtualTick, graphs: PathGraphs) -> None:
        times, reference, refine = graphs.progress_graphs
        size = graphs.progress
        self._runner = runner
        self._progress_at = output_size(graphs) - size - graphs.feedforward
        self._t, self._previous, self._known = np.zeros(1), np.zeros(1), np.zeros(1)
        self._plan, self._guess = np.zeros(size), np.zeros(size)
        self._sampled = np.zeros(size)  # where the reference was last sampled
        self._times = BufferedFunction(times, [self._t, self._previous, self._plan,
                                               self._known], [self._guess])
        self._pose = np.zeros(3)
        self._samples = [np.zeros((size, 3)) for _ in range(3)]
        self._reference = np.zeros(graphs.reference_size)
        self._bounds = np.zeros((size, 2))
        self._sample = BufferedFunction(
            reference, [self._pose, self._guess, self._t, *self._samples],
            [self._reference, self._bounds])
        self._progress, self._settled, self._next = np.zeros(size), np.zeros(1), np.zeros(size)
        self._refine = BufferedFunction(refine, [self._progress, self._guess, self._t],
                                        [self._settled, self._next])
        self.reset()

    def reset(self) -> None:
        """Forget the plan's progress (``mpc_tick_reset``; the last sampled guess stays)."""
        self._has_plan = self._has_previous = self._solved = self._pending = False
        self._rounds = 0

    def times(self, t: float) -> FloatArray:
        self._t[0] = t
        self._known[0] = 1.0 if self._has_plan and self._has_previous else 0.0
        self._times()
        self._previous[0] = t
        self._has_previous = True
        self._rounds = 0 if self._solved else WARM_UP_ROUNDS
        self._pending = False
        return self._guess.copy()

    def step(self, pose: FloatArray, poses: FloatArray, velocities: FloatArray,
             accelerations: FloatArray) -> FloatArray:
        runner = self._runner
        if self._pending:
            runner.again()
        self._pending = False
        self._pose[:] = pose
        for buffer, values in zip(self._samples, (poses, velocities, accelerations),
                                  strict=True):
            buffer[:] = values
        self._sample()
        if all(np.isfinite(float(values.sum())) for values in self._samples):
            self._sampled[:] = self._guess
        out = runner.step(self._pose, self._reference, self._bounds)
        self._solved = int(out[STATUS]) == 0
        progress = out[self._progress_at:self._progress_at + self._plan.size]
        self._plan[:] = progress if self._solved else self._sampled
        self._has_plan = True
        return out

    def again(self) -> FloatArray | None:
        if not self._solved or self._rounds <= 0:
            return None
        self._rounds -= 1
        self._progress[:] = self._runner_progress()
        self._refine()
        if self._settled[0] != 0.0:
            return None
        self._guess[:] = self._next
        self._pending = True
        return self._guess.copy()

    def _runner_progress(self) -> FloatArray:
        """The last step's planned progress (from the runner's output array)."""
        out = self._runner._out
        return out[self._progress_at:self._progress_at + self._plan.size]
