"""The exported C library (:func:`mpc.export_c`) built with CMake and fed recorded ticks:
its commands, statuses and the time of each ``mpc_tick_step``, for ``mpc-bench perf`` and
``mpc-bench export-check``.

A controller's library is written by :func:`mpc.export_c`, built from its own
``CMakeLists.txt`` (``add_subdirectory``) beside a timing program (:data:`HARNESS`), and the
program kept in the library cache (:func:`mpc.model.jit.cache_folder`) under a hash of the
exported sources, the harness and the compiler: the same controller exported again loads
it instead of building it. The program reads every tick from stdin first (the measured
pose, then the reference's poses and world velocities at the stage times, as the exported
``main.c`` reads them), runs them ``rounds`` times from a reset and times each step in C
(no Python, no ctypes): what an embedded caller of the library gets. A path-mode library
(:data:`HARNESS_PATH`) reads the samples the Python controller took each tick
(:class:`SampleLog`, :func:`path_tick_inputs`), runs its three calls a tick on them and
also reports how far the times it asked for are from the recorded ones.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import mpc
from mpc.arrays import FloatArray
from mpc.control.command import Command, Status
from mpc.control.lookahead import Lookahead
from mpc.errors import MpcError
from mpc.model.jit import cache_folder
from mpc.tick.build import keep_whole
from trajectories import TrajectoryError

#: The exported library's status codes (``mpc_tick.h``), in order.
STATUSES = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)

#: The timing program: the exported library's ``mpc_tick_step`` on recorded ticks.
HARNESS = """\
/* Times the exported tick (holonomic-mpc benchmarks/exported.py). Usage:
 *   mpc_tick_timed MAX_ITER BUDGETED REBUILD_DRIFT ROUNDS < ticks
 * Reads every tick first (a line: the pose (3), the reference's poses and world velocities
 * at the stage times (3 (MPC_N + 1) each), as main.c), then runs them ROUNDS times, each
 * from mpc_tick_reset at rest, timing every mpc_tick_step (wall: CLOCK_MONOTONIC; CPU: the
 * thread's clock). Prints the first round's outputs, a line a tick:
 *   C status flag iterations solve_time failures rebuilt twist(3) speeds(MPC_W)
 * then every step's times [s]: T round tick wall cpu */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mpc_tick.h"

#define INPUTS (3 + 6 * (MPC_N + 1))

static double now(clockid_t clock) {
  struct timespec at;
  clock_gettime(clock, &at);
  return (double)at.tv_sec + 1e-9 * (double)at.tv_nsec;
}

int main(int argc, char** argv) {
  static const double rest[3] = {0.0, 0.0, 0.0};
  static double out[MPC_OUT_SIZE];
  size_t capacity = 256, count = 0, k;
  int rounds, round, i, got;
  double *ticks, *outputs, *wall, *cpu;
  mpc_tick* tick;
  if (argc != 5) {
    fprintf(stderr, "usage: %s MAX_ITER BUDGETED REBUILD_DRIFT ROUNDS < ticks\\n", argv[0]);
    return 2;
  }
  rounds = atoi(argv[4]);
  ticks = malloc(capacity * INPUTS * sizeof(double));
  if (!ticks || rounds < 1) return 2;
  for (;;) {
    if (count == capacity) {
      capacity *= 2;
      ticks = realloc(ticks, capacity * INPUTS * sizeof(double));
      if (!ticks) return 2;
    }
    for (i = 0; i < INPUTS; i++) {
      got = scanf("%lf", &ticks[count * INPUTS + i]);
      if (got != 1) break;
    }
    if (i == 0) break;
    if (i != INPUTS) {
      fprintf(stderr, "tick %lu: %d numbers, expected %d\\n", (unsigned long)count, i,
              INPUTS);
      return 2;
    }
    count++;
  }
  outputs = malloc((count ? count : 1) * MPC_OUT_SIZE * sizeof(double));
  wall = malloc((count ? count : 1) * (size_t)rounds * sizeof(double));
  cpu = malloc((count ? count : 1) * (size_t)rounds * sizeof(double));
  tick = mpc_tick_init(atoi(argv[1]), atoi(argv[2]), atof(argv[3]));
  if (!outputs || !wall || !cpu || !tick) return 3;
  for (round = 0; round < rounds; round++) {
    mpc_tick_reset(tick, rest);
    for (k = 0; k < count; k++) {
      const double* line = ticks + k * INPUTS;
      double w = now(CLOCK_MONOTONIC), c = now(CLOCK_THREAD_CPUTIME_ID);
      mpc_tick_step(tick, line, line + 3, line + 3 + 3 * (MPC_N + 1), out);
      cpu[round * count + k] = now(CLOCK_THREAD_CPUTIME_ID) - c;
      wall[round * count + k] = now(CLOCK_MONOTONIC) - w;
      if (round == 0) memcpy(outputs + k * MPC_OUT_SIZE, out, sizeof(out));
    }
  }
  for (k = 0; k < count; k++) {
    const double* o = outputs + k * MPC_OUT_SIZE;
    printf("C %d %d %d %.17g %d %d", (int)o[MPC_OUT_STATUS], (int)o[MPC_OUT_FLAG],
           (int)o[MPC_OUT_ITERATIONS], o[MPC_OUT_SOLVE_TIME], (int)o[MPC_OUT_FAILURES],
           (int)o[MPC_OUT_REBUILT]);
    for (i = 0; i < 3 + MPC_W; i++) printf(" %.17g", o[MPC_OUT_TWIST + i]);
    printf("\\n");
  }
  for (round = 0; round < rounds; round++)
    for (k = 0; k < count; k++)
      printf("T %d %lu %.9e %.9e\\n", round, (unsigned long)k, wall[round * count + k],
             cpu[round * count + k]);
  mpc_tick_free(tick);
  free(ticks);
  free(outputs);
  free(wall);
  free(cpu);
  return 0;
}
"""

#: The timing program of a path-mode library: the same, each tick the library's three
#: calls (mpc_tick_path_times, _step, _again) on the recorded samples (the exported
#: main.c's input, benchmarks/exported.py: path_tick_inputs), timed together.
HARNESS_PATH = """\
/* Times the exported path-mode tick (holonomic-mpc benchmarks/exported.py). Usage:
 *   mpc_tick_timed MAX_ITER BUDGETED REBUILD_DRIFT ROUNDS < ticks
 * Reads every tick first (t, the pose (3), R, then R blocks: ok, the times sampled at,
 * the reference's poses, velocities and accelerations there, as main.c), then runs them
 * ROUNDS times, each from mpc_tick_reset at rest, timing each tick's calls together. Prints
 * the first round's outputs, a line a tick:
 *   C status flag iterations solve_time failures rebuilt twist(3) speeds(MPC_W)
 *   P reference_time time_gap steps
 * (time_gap: the largest |library's times - recorded|, inf where the rounds differ), then
 * every tick's times [s]: T round tick wall cpu */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mpc_tick.h"

#define BLOCK (1 + 10 * MPC_PROGRESS)

static double now(clockid_t clock) {
  struct timespec at;
  clock_gettime(clock, &at);
  return (double)at.tv_sec + 1e-9 * (double)at.tv_nsec;
}

/* One tick (``in``: t, pose, R, R blocks); its gap and steps. */
static void run(mpc_tick* tick, const double* in, double* out, double* reference,
                double* gap, int* steps) {
  static double times[MPC_PROGRESS];
  int r, i, rounds = (int)in[4], stepping = 1;
  const double* block;
  *gap = 0.0;
  *steps = 0;
  mpc_tick_path_times(tick, in[0], times);
  *reference = times[0];
  for (r = 0; r < rounds && stepping; r++) {
    block = in + 5 + r * BLOCK;
    if (r > 0 && !mpc_tick_path_again(tick, times)) {
      *gap = INFINITY;
      break;
    }
    for (i = 0; i < MPC_PROGRESS; i++)
      if (fabs(times[i] - block[1 + i]) > *gap) *gap = fabs(times[i] - block[1 + i]);
    if (block[0] == 0.0) {
      if (r > 0) break;
      *reference = in[0];
    }
    mpc_tick_path_step(tick, in + 1, block + 1 + MPC_PROGRESS, block + 1 + 4 * MPC_PROGRESS,
                       block + 1 + 7 * MPC_PROGRESS, out);
    (*steps)++;
  }
  if (*steps == rounds && mpc_tick_path_again(tick, times)) *gap = INFINITY;
}

int main(int argc, char** argv) {
  static const double rest[3] = {0.0, 0.0, 0.0};
  static double out[MPC_OUT_SIZE];
  size_t capacity = 1 << 16, used = 0, count = 0, k, ticks_capacity = 256;
  int rounds, round, i, r, steps;
  double *data, *outputs, *wall, *cpu, *extra, gap, reference;
  size_t* starts;
  mpc_tick* tick;
  if (argc != 5) {
    fprintf(stderr, "usage: %s MAX_ITER BUDGETED REBUILD_DRIFT ROUNDS < ticks\\n", argv[0]);
    return 2;
  }
  rounds = atoi(argv[4]);
  data = malloc(capacity * sizeof(double));
  starts = malloc(ticks_capacity * sizeof(size_t));
  if (!data || !starts || rounds < 1) return 2;
  for (;;) {
    double head[5];
    size_t need;
    for (i = 0; i < 5; i++)
      if (scanf("%lf", &head[i]) != 1) break;
    if (i == 0) break;
    if (i != 5 || head[4] < 1) {
      fprintf(stderr, "tick %lu: a bad head\\n", (unsigned long)count);
      return 2;
    }
    need = 5 + (size_t)head[4] * BLOCK;
    while (used + need > capacity) {
      capacity *= 2;
      data = realloc(data, capacity * sizeof(double));
      if (!data) return 2;
    }
    if (count == ticks_capacity) {
      ticks_capacity *= 2;
      starts = realloc(starts, ticks_capacity * sizeof(size_t));
      if (!starts) return 2;
    }
    starts[count++] = used;
    memcpy(data + used, head, sizeof(head));
    for (k = 5; k < need; k++)
      if (scanf("%lf", &data[used + k]) != 1) {
        fprintf(stderr, "tick %lu: %lu numbers, expected %lu\\n", (unsigned long)(count - 1),
                (unsigned long)k, (unsigned long)need);
        return 2;
      }
    used += need;
  }
  outputs = malloc((count ? count : 1) * MPC_OUT_SIZE * sizeof(double));
  extra = malloc((count ? count : 1) * 3 * sizeof(double));
  wall = malloc((count ? count : 1) * (size_t)rounds * sizeof(double));
  cpu = malloc((count ? count : 1) * (size_t)rounds * sizeof(double));
  tick = mpc_tick_init(atoi(argv[1]), atoi(argv[2]), atof(argv[3]));
  if (!outputs || !extra || !wall || !cpu || !tick) return 3;
  for (round = 0; round < rounds; round++) {
    mpc_tick_reset(tick, rest);
    for (k = 0; k < count; k++) {
      double w = now(CLOCK_MONOTONIC), c = now(CLOCK_THREAD_CPUTIME_ID);
      run(tick, data + starts[k], out, &reference, &gap, &steps);
      cpu[round * count + k] = now(CLOCK_THREAD_CPUTIME_ID) - c;
      wall[round * count + k] = now(CLOCK_MONOTONIC) - w;
      if (round == 0) {
        memcpy(outputs + k * MPC_OUT_SIZE, out, sizeof(out));
        extra[3 * k] = reference;
        extra[3 * k + 1] = gap;
        extra[3 * k + 2] = steps;
      }
    }
  }
  for (k = 0; k < count; k++) {
    const double* o = outputs + k * MPC_OUT_SIZE;
    printf("C %d %d %d %.17g %d %d", (int)o[MPC_OUT_STATUS], (int)o[MPC_OUT_FLAG],
           (int)o[MPC_OUT_ITERATIONS], o[MPC_OUT_SOLVE_TIME], (int)o[MPC_OUT_FAILURES],
           (int)o[MPC_OUT_REBUILT]);
    for (i = 0; i < 3 + MPC_W; i++) printf(" %.17g", o[MPC_OUT_TWIST + i]);
    printf("\\nP %.17g %.17g %d\\n", extra[3 * k], extra[3 * k + 1], (int)extra[3 * k + 2]);
  }
  for (round = 0; round < rounds; round++)
    for (k = 0; k < count; k++)
      printf("T %d %lu %.9e %.9e\\n", round, (unsigned long)k, wall[round * count + k],
             cpu[round * count + k]);
  (void)r;
  mpc_tick_free(tick);
  free(data);
  free(starts);
  free(outputs);
  free(extra);
  free(wall);
  free(cpu);
  return 0;
}
"""

#: The timing program's project: the exported library from its own CMakeLists.txt.
_PROJECT = """\
cmake_minimum_required(VERSION 3.13)
project(mpc_tick_timing C)
add_subdirectory(${CMAKE_CURRENT_SOURCE_DIR}/../src mpc_tick)
add_executable(mpc_tick_timed timed.c)
target_link_libraries(mpc_tick_timed PRIVATE mpc_tick)
"""


class ExportBuildError(MpcError):
    """The exported library could not be built (no cmake, no compiler, or it failed)."""


@dataclass(frozen=True)
class Replay:
    """What the exported library did with recorded ticks (K ticks, R rounds).

    Attributes:
        status: each tick's status code (K,) (:data:`STATUSES`), first round.
        flag: daqp's exit flag (K,); iterations (K,); solve_time [s] (K,); failures (K,)
            in a row; rebuilt (K,): Hessians built that tick.
        twist: the commanded twists (K, 3) [m/s, m/s, rad/s]; speeds (K, W) [rad/s].
        wall, cpu: each step's wall-clock and thread CPU time (R, K) [s].
    """

    status: np.ndarray
    flag: np.ndarray
    iterations: np.ndarray
    solve_time: FloatArray
    failures: np.ndarray
    rebuilt: np.ndarray
    twist: FloatArray
    speeds: FloatArray
    wall: FloatArray
    cpu: FloatArray
    #: Path mode: each tick's reference time tracked [s], the largest difference between
    #: the times the library asked to sample at and the recorded ones [s] (inf where they
    #: took a different number of warm-up rounds), and the steps made (K,) each.
    reference_time: FloatArray | None = None
    time_gap: FloatArray | None = None
    steps: np.ndarray | None = None


class ExportedTick:
    """``controller``'s tick exported (:func:`mpc.export_c`) and built with CMake, with the
    controller's iteration limit, budget and Hessian rule.

    Attributes:
        program: the timing program's path. build_time: seconds spent exporting and
        building (or loading it from the cache). cached: it came from the cache.

    Raises:
        ExportBuildError: cmake or the compiler is missing or failed.
        ControllerError: the controller does not run the compiled tick.
    """

    def __init__(self, controller: Any) -> None:
        started = time.perf_counter()
        if controller.robot.steer_states:  # (tick_inputs has no measured steer angles)
            raise ExportBuildError("casters: the timing program is not fed measured steer "
                                   "angles yet")
        compiled = controller._compiled  # (export_c refuses a controller without one)
        #: Path mode: the library's three calls a tick, fed :func:`path_tick_inputs`.
        self.path = getattr(controller, "mode", "time") == "path"
        self._harness = HARNESS_PATH if self.path else HARNESS
        work = Path(tempfile.mkdtemp(prefix="mpc-export-"))
        self._private: Path | None = None  # a program outside the cache: removed with self
        try:
            mpc.export_c(controller, work / "src")
            key = _key(work / "src", self._harness)
            folder = cache_folder()
            cached = None if folder is None else folder / f"mpc_export_timed-{key}"
            self.cached = cached is not None and cached.is_file()
            if cached is not None and self.cached:
                self.program = cached
            else:
                built = _build(work, self._harness)
                if cached is not None and keep_whole(built, cached, 0o755):
                    self.program = cached
                else:  # no cache: a private copy that outlives the build folder
                    handle, name = tempfile.mkstemp(prefix="mpc_export_timed-")
                    os.close(handle)
                    shutil.copyfile(built, name)
                    os.chmod(name, 0o755)
                    self.program = self._private = Path(name)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        self.arguments = [str(int(compiled.max_iter)), str(int(compiled.budgeted)),
                          repr(float(compiled.rebuild_drift))]
        self.wheels = int(compiled.graphs.wheels)
        self.build_time = time.perf_counter() - started

    def __del__(self) -> None:
        private, self._private = getattr(self, "_private", None), None
        if private is not None:
            private.unlink(missing_ok=True)

    def replay(self, inputs: str, rounds: int = 1) -> Replay:
        """The program on ``inputs`` (:func:`tick_inputs`), ``rounds`` times from a reset.

        Raises:
            ExportBuildError: the program failed (its last words in the message)."""
        done = subprocess.run([str(self.program), *self.arguments, str(rounds)], input=inputs,
                              capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise ExportBuildError(f"the exported library's program failed (exit "
                                   f"{done.returncode}): {done.stderr.strip()[-300:]}")
        outputs, times, progress = [], [], []
        for line in done.stdout.splitlines():
            if line.startswith("C "):
                outputs.append([float(word) for word in line.split()[1:]])
            elif line.startswith("T "):
                times.append([float(word) for word in line.split()[1:]])
            elif line.startswith("P "):
                progress.append([float(word) for word in line.split()[1:]])
        count = len(outputs)
        if count == 0 or len(times) != rounds * count:
            raise ExportBuildError(f"the exported library's program printed {count} ticks "
                                   f"and {len(times)} times for {rounds} rounds")
        out, timing = np.array(outputs), np.array(times)
        return Replay(status=out[:, 0].astype(int), flag=out[:, 1].astype(int),
                      iterations=out[:, 2].astype(int), solve_time=out[:, 3],
                      failures=out[:, 4].astype(int), rebuilt=out[:, 5].astype(int),
                      twist=out[:, 6:9], speeds=out[:, 9:9 + self.wheels],
                      wall=timing[:, 2].reshape(rounds, count),
                      cpu=timing[:, 3].reshape(rounds, count),
                      **(_path_fields(np.array(progress), count) if self.path else {}))


def tick_inputs(controller: Any, times: Sequence[float], poses: Sequence[Any]) -> str:
    """The program's stdin for ticks at ``times`` [s] with measured ``poses`` (K, 3): each
    line the pose, then ``controller``'s reference at the stage times as it samples it
    (NaN where the trajectory cannot be sampled: the library falls back)."""
    ahead = Lookahead(controller.trajectory, controller.model.offsets, controller.dt)
    stages = len(controller.model.offsets)
    lines = []
    for t, pose in zip(times, poses, strict=True):
        try:
            window, velocities = ahead.window(float(t))
        except TrajectoryError:
            window = velocities = np.full((stages, 3), math.nan)
        numbers = np.concatenate([np.asarray(pose, dtype=float), np.ravel(window),
                                  np.ravel(velocities)])
        lines.append(" ".join(repr(float(value)) for value in numbers))
    return "\n".join(lines) + "\n"


def _path_fields(progress: np.ndarray, count: int) -> dict[str, Any]:
    """A path-mode replay's ``P`` lines as :class:`Replay`'s path fields."""
    if progress.shape != (count, 3):
        raise ExportBuildError(f"the exported library's program printed {len(progress)} "
                               f"path lines for {count} ticks")
    return {"reference_time": progress[:, 0], "time_gap": progress[:, 1],
            "steps": progress[:, 2].astype(int)}


class SampleLog:
    """Every sample a trajectory gives (path mode's recording): its ``sample`` wrapped on
    the instance. ``calls``: (times, sample or None where it raised) in order."""

    def __init__(self, trajectory: Any) -> None:
        self.calls: list[tuple[np.ndarray, Any]] = []
        original = trajectory.sample

        def sample(t: Any) -> Any:
            times = np.array(t, dtype=float)
            try:
                result = original(t)
            except TrajectoryError:
                self.calls.append((times, None))
                raise
            self.calls.append((times, result))
            return result

        object.__setattr__(trajectory, "sample", sample)

    def take(self) -> list[tuple[np.ndarray, Any]]:
        """The calls since the last take."""
        calls, self.calls = self.calls, []
        return calls


def path_tick_inputs(times: Sequence[float], poses: Sequence[Any],
                     samples: Sequence[Sequence[tuple[np.ndarray, Any]]]) -> str:
    """A path-mode program's stdin (the exported ``main.c``'s and :data:`HARNESS_PATH`'s):
    each tick's time [s], measured pose, and the reference's samples the Python controller
    took that tick (:class:`SampleLog`: the progress guess, then each warm-up round; NaN
    where the trajectory raised)."""
    lines = []
    for t, pose, calls in zip(times, poses, samples, strict=True):
        numbers = [float(t), *np.asarray(pose, dtype=float).tolist(), float(len(calls))]
        for at, sample in calls:
            stages = at.size
            if sample is None:
                values = np.full(9 * stages, math.nan)
            else:
                values = np.concatenate([np.ravel(sample.pose), np.ravel(sample.velocity),
                                         np.ravel(sample.acceleration)])
            numbers += [0.0 if sample is None else 1.0, *at.tolist(), *values.tolist()]
        lines.append(" ".join(repr(value) for value in numbers))
    return "\n".join(lines) + "\n"


def differences(replay: Replay, twists: FloatArray, speeds: FloatArray,
                statuses: Sequence[Status]) -> tuple[float, int]:
    """The largest difference of a twist component or wheel speed between the library's
    ticks and ``twists`` (K, 3), ``speeds`` (K, W) (inf where one side is NaN and the
    other not), and the ticks whose status differs from ``statuses``."""
    ours = np.hstack([replay.twist, replay.speeds])
    theirs = np.hstack([np.asarray(twists, dtype=float), np.asarray(speeds, dtype=float)])
    gap = np.abs(ours - theirs)
    both_nan = np.isnan(ours) & np.isnan(theirs)
    gap = np.where(both_nan, 0.0, np.where(np.isnan(gap), math.inf, gap))
    mismatches = sum(STATUSES[code] is not Status(status)
                     for code, status in zip(replay.status, statuses, strict=True))
    return float(gap.max(initial=0.0)), int(mismatches)


def command_differences(replay: Replay, commands: Sequence[Command]) -> tuple[float, int]:
    """:func:`differences` against a list of :class:`~mpc.Command`."""
    return differences(replay, np.array([command.twist for command in commands]),
                       np.array([command.wheel_speeds for command in commands]),
                       [command.status for command in commands])


def _key(source: Path, harness: str = HARNESS) -> str:
    """What the timing program depends on, hashed: the exported files, the harness, the
    compiler and cmake."""
    digest = hashlib.sha256()
    for name in sorted(os.listdir(source)):
        digest.update(name.encode())
        digest.update((source / name).read_bytes())
    digest.update(harness.encode())
    digest.update(_PROJECT.encode())
    digest.update((os.environ.get("CC") or "cc").encode())
    return digest.hexdigest()[:32]


def _build(work: Path, harness: str = HARNESS) -> Path:
    """The timing program built in ``work`` (the export in ``work/src``) with CMake."""
    cmake = shutil.which("cmake")
    if cmake is None:
        raise ExportBuildError("building the exported library needs cmake (not found)")
    project = work / "timing"
    project.mkdir()
    (project / "CMakeLists.txt").write_text(_PROJECT)
    (project / "timed.c").write_text(harness)
    build = work / "build"
    for command in ([cmake, "-S", str(project), "-B", str(build)],
                    [cmake, "--build", str(build)]):
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            words = (done.stderr or done.stdout).strip().splitlines()[-3:]
            raise ExportBuildError(f"building the exported library failed ({' '.join(command[:2])}"
                                   f", exit {done.returncode}): " + " / ".join(words))
    program = build / "mpc_tick_timed"
    if not program.is_file():
        raise ExportBuildError("building the exported library wrote no program")
    return program
