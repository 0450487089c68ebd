"""``mpc.export_c(controller, folder)``: one controller's tick as a self-contained C library
(the generated graphs, ``tick.c``, one header, a ``CMakeLists.txt``, a README of the
interface and an example ``main.c``), daqp linked from the casadi wheel that generated it
(its ``include/daqp`` and ``libdaqpstat.a``) or, for another target, built from daqp's
released source (``-DMPC_DAQP_SOURCE``, ``daqp.cmake``); none of daqp's code is copied.

The reference is the caller's: in time mode each tick takes the reference's poses and
world velocities at the stage times (``t + MPC_STAGE_OFFSETS``), as the controller samples
them; in path mode the library gives the times to sample at (the progress guess,
``mpc_tick_path_times``; the warm-up's rounds, ``mpc_tick_path_again``) and each step takes
the poses, world velocities and accelerations there (``mpc_tick_path_step``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from mpc.errors import ControllerError
from mpc.robots.base import Robot
from mpc.tick.build import casadi_folder, write_sources
from mpc.tick.edge import CompiledTick
from mpc.tick.path import PathGraphs
from mpc.tick.screen import LIBRARY_AFTER


class Exportable(Protocol):
    """What :func:`export_c` reads of a :class:`~mpc.control.Controller`."""

    robot: Robot
    dt: float
    horizon: int

    @property
    def tick_path(self) -> str: ...


def export_c(controller: Exportable, folder: str | Path) -> Path:
    """Write ``controller``'s tick as a C library into ``folder`` (made if missing; files of
    the same names replaced): the controller must run the compiled tick
    (``Controller(..., compiled=True)`` or ``"virtual-machine"``). Returns the folder.

    Raises:
        ControllerError: the controller does not run the compiled tick.
    """
    compiled = getattr(controller, "_compiled", None)
    if not isinstance(compiled, CompiledTick):
        raise ControllerError(
            "export_c needs a controller built with compiled=True (or 'virtual-machine'): "
            f"this one runs the {controller.tick_path!r} tick")
    path = isinstance(compiled.graphs, PathGraphs)
    out = Path(folder)
    graphs = compiled.graphs
    write_sources(graphs, out)
    casadi = casadi_folder()
    (out / "CMakeLists.txt").write_text(_CMAKE.replace("@CASADI_DIR@", casadi.as_posix()))
    (out / "daqp.cmake").write_text(_DAQP_CMAKE.replace("@DAQP_RELEASE@", DAQP_RELEASE))
    robot = controller.robot
    main = (_MAIN_PATH if path else _MAIN).replace(
        "mpc_tick_init(1000, 0, 1.0)",
        f"mpc_tick_init({compiled.max_iter}, {int(compiled.budgeted)}, "
        f"{compiled.rebuild_drift!r})")
    if robot.steer_states:  # casters: each line ends with the measured steer angles
        main = main.replace("#define MPC_MEASURED_STEER 0", "#define MPC_MEASURED_STEER 1")
    if graphs.screen_places and compiled.screen_after != LIBRARY_AFTER:  # as the controller
        main = main.replace("  mpc_tick_reset(tick, rest);",
                            f"  mpc_tick_set_screen(tick, {compiled.screen_after});\n"
                            "  mpc_tick_reset(tick, rest);")
    (out / "main.c").write_text(main)
    (out / "README.md").write_text(_README.format(
        robot=robot.name, kind=robot.kind, wheels=robot.n_wheels, horizon=graphs.horizon,
        dt=graphs.tick, offsets=", ".join(f"{value:g}" for value in graphs.offsets),
        casadi=casadi.as_posix(), max_iter=compiled.max_iter, mode="path" if path else "time",
        rebuild=compiled.rebuild_drift, daqp=DAQP_RELEASE) + (_README_PATH if path else ""))
    return out


_CMAKE = """\
# One holonomic-mpc controller's tick as a C library (mpc.export_c).
cmake_minimum_required(VERSION 3.13)
project(mpc_tick C)
if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release)
endif()
# The casadi wheel's folder: daqp's headers (include/daqp) and static library.
set(CASADI_DIR "@CASADI_DIR@" CACHE PATH "folder with include/daqp and libdaqpstat.a")
# daqp built from its released source for the target (cross builds) instead of the
# wheel's x86-64 libdaqpstat.a: an unpacked sdist, or its csrc folder (see README.md).
set(MPC_DAQP_SOURCE "" CACHE PATH "daqp's source (sdist) to build for the target")
add_library(mpc_tick STATIC tick.c mpc_tick_graphs.c)
target_include_directories(mpc_tick PUBLIC ${CMAKE_CURRENT_SOURCE_DIR})
set_source_files_properties(mpc_tick_graphs.c PROPERTIES COMPILE_OPTIONS "-O2")
set_source_files_properties(tick.c PROPERTIES COMPILE_OPTIONS "-O3")
if(MPC_DAQP_SOURCE)
  include(${CMAKE_CURRENT_SOURCE_DIR}/daqp.cmake)
  target_link_libraries(mpc_tick PUBLIC mpc_daqp m)
elseif(CMAKE_CROSSCOMPILING)
  message(FATAL_ERROR "cross-compiling needs daqp built for the target: "
          "-DMPC_DAQP_SOURCE=<unpacked daqp sdist> (the wheel's libdaqpstat.a is x86-64)")
else()
  target_include_directories(mpc_tick PUBLIC ${CASADI_DIR}/include)
  target_link_libraries(mpc_tick PUBLIC ${CASADI_DIR}/libdaqpstat.a m)
endif()
add_executable(mpc_tick_example main.c)
target_link_libraries(mpc_tick_example PRIVATE mpc_tick)
"""

# daqp's released source for a cross build (CMakeLists.txt's MPC_DAQP_SOURCE): tick.c uses
# daqp's internals (update_ldp, the UPDATE_* masks), so the release must be the one whose
# headers are the casadi wheel's include/daqp (casadi 3.8.2's: tests/test_export_cross.py).
DAQP_RELEASE = "0.5.1"

_DAQP_CMAKE = """\
# daqp built from its released source for the target (CMakeLists.txt, MPC_DAQP_SOURCE):
#   pip download --no-binary :all: --no-deps daqp==@DAQP_RELEASE@
#   tar xzf daqp-@DAQP_RELEASE@.tar.gz
if(EXISTS "${MPC_DAQP_SOURCE}/csrc/src/api.c")
  set(DAQP_C "${MPC_DAQP_SOURCE}/csrc")
else()
  set(DAQP_C "${MPC_DAQP_SOURCE}")
endif()
if(NOT EXISTS "${DAQP_C}/src/api.c" OR NOT EXISTS "${DAQP_C}/include/api.h")
  message(FATAL_ERROR "MPC_DAQP_SOURCE=${MPC_DAQP_SOURCE}: expected daqp's source "
          "(csrc/src/api.c and csrc/include/api.h of daqp-@DAQP_RELEASE@.tar.gz)")
endif()
# tick.c is written against the generating wheel's daqp: its headers, where present here.
foreach(header api.h types.h constants.h utils.h)
  if(EXISTS "${CASADI_DIR}/include/daqp/${header}")
    file(READ "${CASADI_DIR}/include/daqp/${header}" expected)
    file(READ "${DAQP_C}/include/${header}" found)
    if(NOT expected STREQUAL found)
      message(FATAL_ERROR "${DAQP_C}/include/${header} differs from the casadi wheel's "
              "${CASADI_DIR}/include/daqp/${header}: use daqp @DAQP_RELEASE@'s source")
    endif()
  endif()
endforeach()
file(GLOB DAQP_SOURCES "${DAQP_C}/src/*.c")
add_library(mpc_daqp STATIC ${DAQP_SOURCES})
# PROFILING: daqp times its solves (MPC_OUT_SOLVE_TIME), as in the casadi wheel's build.
target_compile_definitions(mpc_daqp PUBLIC PROFILING)
target_compile_options(mpc_daqp PRIVATE -O3)
target_include_directories(mpc_daqp PRIVATE "${DAQP_C}/include")
# tick.c includes <daqp/api.h>: the headers under a daqp/ folder of the build tree.
file(COPY "${DAQP_C}/include/" DESTINATION "${CMAKE_CURRENT_BINARY_DIR}/daqp-include/daqp"
     FILES_MATCHING PATTERN "*.h")
target_include_directories(mpc_daqp PUBLIC "${CMAKE_CURRENT_BINARY_DIR}/daqp-include")
target_link_libraries(mpc_daqp PUBLIC m)
"""

_MAIN = """\
/* Example: the exported controller (its max_iter and budget) fed recorded ticks. Each
 * line of stdin is one tick: the measured pose (3 numbers), then the reference's poses
 * and world velocities at the stage times (3 (MPC_N + 1) numbers each, a stage's three
 * together). Each line of stdout: the status, the twist (3), the wheel speeds and (swerve)
 * the steer angles. Swerve modules start straight ahead; each step starts from the angles
 * the last commanded (mpc_tick_set_steer_angles sets measured ones). Casters
 * (MPC_MEASURED_STEER 1): each input line ends with the measured steer angles (MPC_STEER),
 * set before the step; the steer angles printed are the measured ones plus the steer rates
 * to send times MPC_DT. */
#include <stdio.h>

#include "mpc_tick.h"

#define MPC_MEASURED_STEER 0
#define INPUTS (3 + 6 * (MPC_N + 1) + MPC_MEASURED_STEER * MPC_STEER)

int main(void) {
  static double line[INPUTS], out[MPC_OUT_SIZE];
  const double rest[3] = {0.0, 0.0, 0.0};
  mpc_tick* tick = mpc_tick_init(1000, 0, 1.0);
  int i;
  if (!tick) return 1;
  mpc_tick_reset(tick, rest);
  for (;;) {
    for (i = 0; i < INPUTS; i++)
      if (scanf("%lf", &line[i]) != 1) {
        mpc_tick_free(tick);
        return 0;
      }
#if MPC_MEASURED_STEER
    mpc_tick_set_steer_angles(tick, line + 3 + 6 * (MPC_N + 1));
#endif
    mpc_tick_step(tick, line, line + 3, line + 3 + 3 * (MPC_N + 1), out);
    printf("%d", (int)out[MPC_OUT_STATUS]);
    for (i = 0; i < 3 + MPC_W; i++) printf(" %.17g", out[MPC_OUT_TWIST + i]);
    for (i = 0; i < MPC_STEER; i++) printf(" %.17g", out[MPC_OUT_STEER + i]);
    printf("\\n");
  }
}
"""

_MAIN_PATH = """\
/* Example: the exported path-mode controller (its max_iter and budget) fed recorded ticks.
 * Each tick is: t [s], the measured pose (3), R (the times the recording sampled the
 * reference this tick, warm-up rounds included), then R blocks, each: ok (1, or 0 where
 * the reference could not be sampled), the times sampled at (MPC_PROGRESS), the
 * reference's poses, world velocities and accelerations there (3 MPC_PROGRESS each, a
 * stage's three numbers together; NaN where not ok). The library says where to sample
 * (mpc_tick_path_times, mpc_tick_path_again); a caller with the trajectory at hand samples
 * there; here the recording's samples are used, and each line of stdout is the status, the
 * twist (3), the wheel speeds, the reference time tracked [s], the largest difference
 * between the library's times and the recording's [s] (inf where they took a different
 * number of rounds) and the steps made. */
#include <math.h>
#include <stdio.h>

#include "mpc_tick.h"

#define BLOCK (1 + 10 * MPC_PROGRESS)

static int read_numbers(double* x, int n) {
  int i;
  for (i = 0; i < n; i++)
    if (scanf("%lf", &x[i]) != 1) return 0;
  return 1;
}

int main(void) {
  static double head[5], block[BLOCK], times[MPC_PROGRESS], out[MPC_OUT_SIZE];
  const double rest[3] = {0.0, 0.0, 0.0};
  mpc_tick* tick = mpc_tick_init(1000, 0, 1.0);
  int i, r, rounds, steps, stepping;
  if (!tick) return 1;
  mpc_tick_reset(tick, rest);
  while (read_numbers(head, 5)) {
    double gap = 0.0, reference_time;
    const double* pose = head + 1;
    rounds = (int)head[4];
    mpc_tick_path_times(tick, head[0], times);
    reference_time = times[0];
    steps = 0;
    stepping = 1;
    for (r = 0; r < rounds; r++) {
      if (!read_numbers(block, BLOCK)) return 2;
      if (!stepping) continue;
      if (r > 0 && !mpc_tick_path_again(tick, times)) { /* the recording made more rounds */
        gap = INFINITY;
        stepping = 0;
        continue;
      }
      for (i = 0; i < MPC_PROGRESS; i++)
        if (fabs(times[i] - block[1 + i]) > gap) gap = fabs(times[i] - block[1 + i]);
      if (r > 0 && block[0] == 0.0) { /* no reference there: the last step stands */
        stepping = 0;
        continue;
      }
      if (r == 0 && block[0] == 0.0) reference_time = head[0];
      mpc_tick_path_step(tick, pose, block + 1 + MPC_PROGRESS, block + 1 + 4 * MPC_PROGRESS,
                         block + 1 + 7 * MPC_PROGRESS, out);
      steps++;
    }
    if (stepping && steps == rounds && steps > 0 && mpc_tick_path_again(tick, times))
      gap = INFINITY; /* the library asks for a round the recording did not make */
    printf("%d", (int)out[MPC_OUT_STATUS]);
    for (i = 0; i < 3 + MPC_W; i++) printf(" %.17g", out[MPC_OUT_TWIST + i]);
    printf(" %.17g %.17g %d\\n", reference_time, gap, steps);
  }
  mpc_tick_free(tick);
  return 0;
}
"""

_README_PATH = """
## Path mode

The reference is sampled where the progress is (the reference time reached at each stage,
planned with the motion), which the last plan decides: a tick is three calls.

    double times[MPC_PROGRESS], poses[3 * MPC_PROGRESS], velocities[3 * MPC_PROGRESS];
    double accelerations[3 * MPC_PROGRESS], out[MPC_OUT_SIZE];
    mpc_tick_path_times(tick, t, times);        /* where to sample this tick [s] */
    sample(times, poses, velocities, accelerations);
    mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
    while (mpc_tick_path_again(tick, times)) {  /* warm-up after a start with no plan */
      if (!sample(times, poses, velocities, accelerations)) break;  /* the step stands */
      mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
    }
    /* send out[MPC_OUT_SPEEDS ...] */

- `void mpc_tick_path_times(mpc_tick*, double t, double times[N+1])`: the tick's time
  `t` [s] in; the N+1 times [s] of the reference's own clock at which to sample it out.
- `int mpc_tick_path_step(mpc_tick*, const double pose[3], const double poses[3 (N+1)],
  const double velocities[3 (N+1)], const double accelerations[3 (N+1)],
  double out[MPC_OUT_SIZE])`: the reference's poses (x, y, theta) [m, m, rad], world
  velocities [m/s, m/s, rad/s] and accelerations [m/s^2, m/s^2, rad/s^2] at those times, a
  stage's three numbers together; NaN where the reference cannot be sampled (the fallback
  runs). Returns the status; `out` as `mpc_tick_step`'s, and `MPC_OUT_PROGRESS` (N+1) the
  planned progress [s].
- `int mpc_tick_path_again(mpc_tick*, double times[N+1])`: after a step with no plan to
  start from (the first tick, after a reset or a failure), 1 and new times while the
  progress has not settled (at most `MPC_WARM_UP_ROUNDS` rounds), else 0. If the reference
  cannot be sampled at them, stop: the last step's command stands.

The reference time tracked now is `times[0]` of `mpc_tick_path_times` (`t` when the
reference could not be sampled). `mpc_tick_reset` forgets the progress as well.
"""

_README = """\
# A holonomic-mpc controller as C (mpc.export_c)

Robot `{robot}` ({kind}, {wheels} wheels), horizon N = {horizon}, control tick {dt:g} s,
{mode} mode. Generated by holonomic-mpc; the numbers come from the same CasADi graphs as
`Controller(..., compiled=True)`.

Build (CMake >= 3.13, a C compiler; daqp from the casadi wheel at `{casadi}`, or give
`-DCASADI_DIR=` a folder with `include/daqp` and `libdaqpstat.a`):

    cmake -S . -B build && cmake --build build
    ./build/mpc_tick_example < ticks.txt

For another target, build daqp from its released source (`daqp.cmake`; daqp {daqp}, whose
headers are the casadi wheel's) with the target's compiler, e.g. 32-bit ARM:

    pip download --no-binary :all: --no-deps daqp=={daqp} && tar xzf daqp-{daqp}.tar.gz
    cmake -S . -B arm -DMPC_DAQP_SOURCE=$PWD/daqp-{daqp} -DCMAKE_SYSTEM_NAME=Linux \\
      -DCMAKE_C_COMPILER=arm-linux-gnueabihf-gcc -DCMAKE_EXE_LINKER_FLAGS=-static
    cmake --build arm && qemu-arm ./arm/mpc_tick_example < ticks.txt

## Interface (`mpc_tick.h`)

- `mpc_tick* mpc_tick_init(int max_iter, int budgeted, double rebuild_drift)`: allocates
  everything (the controller used `max_iter` {max_iter} and `rebuild_drift` {rebuild}: the
  Hessian is kept across ticks until the linearisation moved beyond that multiple of its
  tolerance; below 0 it is rebuilt every tick); `mpc_tick_free` releases it.
- `void mpc_tick_reset(mpc_tick*, const double last[3])`: forget the plan; `last` is the
  body twist executing now (zeros at rest).
- `int mpc_tick_step(mpc_tick*, const double pose[3], const double ref_poses[3 (N+1)],
  const double ref_velocities[3 (N+1)], double out[MPC_OUT_SIZE])`: one tick, no
  allocation. `ref_poses` and `ref_velocities` are the reference at `t + offsets`, offsets
  = ({offsets}) s (`MPC_STAGE_OFFSETS`), a stage's three numbers together. (Time mode;
  path mode's tick is three calls, below.)

Units: m, rad, s. Poses (x, y, theta) in the world frame; twists (vx, vy, omega) in the
body frame [m/s, m/s, rad/s]; reference velocities (dx/dt, dy/dt, dtheta/dt) in the world
frame; wheel speeds [rad/s] in the robot's wheel order (holonomic-mpc's kinematics
conventions).

`out`: `MPC_OUT_STATUS` (0 solved, 1 previous plan, 2 feedforward, 3 stopping: the
fallbacks, in order), `MPC_OUT_FLAG` (daqp's exit flag; -1000: the reference had a NaN),
`MPC_OUT_ITERATIONS`, `MPC_OUT_SOLVE_TIME` [s], `MPC_OUT_CLAMPED`, `MPC_OUT_FAILURES`,
`MPC_OUT_REBUILT` (Hessians built this tick), `MPC_OUT_TWIST` (3), `MPC_OUT_SPEEDS`
(MPC_W wheel speeds to send), `MPC_OUT_POSES` (the plan, 3 (N+1)), for a swerve robot
`MPC_OUT_STEER` (MPC_STEER steer angles [rad] in (-pi, pi] to send with the signed wheel
speeds), and with a motor model `MPC_OUT_FEEDFORWARD` (`MPC_FF` = 5 MPC_W: per wheel the
drive force at the floor [N], each motor's torque [N m] and current [A], then each wheel's
contact force (x, y) [N], body frame). Every command is within every wheel's speed and
acceleration limit (and a swerve module's steering rate; with a motor model, its battery
voltage, current and traction limits).

Swerve (`MPC_STEER` > 0): each step starts from the steer angles the last one commanded
(straight ahead after `mpc_tick_init`); `void mpc_tick_set_steer_angles(mpc_tick*, const
double angles[MPC_STEER])` sets them before a step (measured angles, or after a reset).
Powered casters: their steer angles are the robot's state, so set the measured ones before
every step; `MPC_OUT_STEER` then has the measured angles plus the steer rates to send
times `MPC_DT` (the rates: the difference over `MPC_DT`), `MPC_OUT_SPEEDS` the drive rates.

Row screen (`MPC_SCREEN_ROWS` > 0: a motor model's rows, swerve's guard faces): rows no
plan has needed for `MPC_SCREEN_AFTER` ticks leave daqp's problem, each plan is checked
against them and solved again with those it breaks (the same optimum; with a budget the
solves share `max_iter`); `void mpc_tick_set_screen(mpc_tick*, int after)` changes the
ticks (0: every row in daqp's problem) and `mpc_tick_screen_counts` reports rows in daqp's
last problem and the solves again so far.
"""
