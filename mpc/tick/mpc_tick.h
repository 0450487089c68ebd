/* The compiled tick's interface (holonomic-mpc, mpc/tick): one controller's tick as one C
 * program. Units: m, rad, s; twists (vx, vy, omega) in the body frame [m/s, m/s, rad/s];
 * wheel speeds [rad/s] in the robot's wheel order. */
#ifndef MPC_TICK_H
#define MPC_TICK_H

#include "mpc_tick_config.h"

/* Time mode's sizes where the configuration does not set path mode's. */
#ifndef MPC_PROGRESS
#define MPC_PROGRESS 0                  /* progress values in a plan (path mode: N+1) */
#define MPC_REF_SIZE (3 * (MPC_N + 1))  /* numbers in mpc_tick_step's ref_poses */
#define MPC_REF2_SIZE (3 * (MPC_N + 1)) /* numbers in mpc_tick_step's ref_velocities */
#define MPC_AGAIN_MODE 3
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mpc_tick mpc_tick;

/* Status codes (out[MPC_OUT_STATUS]), as holonomic-mpc's Command.status. */
#define MPC_SOLVED 0        /* the QP solved: its first twist, clamped into the limits */
#define MPC_PREVIOUS_PLAN 1 /* fallback: the last plan, read on */
#define MPC_FEEDFORWARD 2   /* fallback: the reference's feedforward within the limits */
#define MPC_STOPPING 3      /* fallback: a stop within the acceleration limits */

/* Layout of the output array mpc_tick_step writes (MPC_OUT_SIZE numbers). */
#define MPC_OUT_STATUS 0     /* one of the status codes */
#define MPC_OUT_FLAG 1       /* daqp's exit flag (1, 2: solved; -1000: no reference) */
#define MPC_OUT_ITERATIONS 2 /* daqp's iterations this tick */
#define MPC_OUT_SOLVE_TIME 3 /* daqp's time this tick [s] */
#define MPC_OUT_CLAMPED 4    /* 1 if the clamp changed the twist */
#define MPC_OUT_FAILURES 5   /* failed ticks in a row, this one included */
#define MPC_OUT_REBUILT 6    /* Hessians built this tick (0: the kept one was used) */
#define MPC_OUT_TWIST 7      /* the commanded twist (3) */
#define MPC_OUT_SPEEDS (MPC_OUT_TWIST + 3)      /* the wheel speeds to send (MPC_W) */
#define MPC_OUT_POSES (MPC_OUT_SPEEDS + MPC_W)  /* the plan's poses (3 (MPC_N + 1)) */
#define MPC_OUT_STEER (MPC_OUT_POSES + 3 * (MPC_N + 1)) /* swerve: steer angles (MPC_STEER) */
#define MPC_OUT_PROGRESS (MPC_OUT_STEER + MPC_STEER) /* path mode: progress [s] (MPC_PROGRESS) */
/* robots with a motor model (MPC_FF = 5 MPC_W, else 0): per wheel the drive force at the
 * floor [N], each motor's torque [N m] and current [A], then the contact force vectors
 * (x, y per wheel, body frame) [N], as Command.wheel_forces, motor_torques,
 * motor_currents, contact_forces */
#define MPC_OUT_FEEDFORWARD (MPC_OUT_PROGRESS + MPC_PROGRESS)
#define MPC_OUT_SIZE (MPC_OUT_FEEDFORWARD + MPC_FF)
#if MPC_STEER && MPC_PROGRESS
#error "the compiled tick has no path mode for swerve"
#endif
#if MPC_FF && (MPC_STEER || MPC_PROGRESS)
#error "the compiled tick has no motor model for swerve or in path mode"
#endif

/* A controller (allocates everything it will use; NULL if daqp cannot be set up).
 * max_iter: daqp iterations per solve at most; budgeted: 1 if max_iter was chosen (no
 * second solve from the last command after a failed cold start), else 0; rebuild_drift:
 * the Hessian kept across ticks is rebuilt when the sensitivities moved beyond this
 * multiple of their tolerance (the exported main.c passes the controller's; below 0: every
 * tick, no reuse). */
mpc_tick* mpc_tick_init(int max_iter, int budgeted, double rebuild_drift);
void mpc_tick_free(mpc_tick* tick);
/* Forget the plan, the failures, daqp's active set and the kept Hessian; last: the twist
 * executing now. */
void mpc_tick_reset(mpc_tick* tick, const double* last);
/* One tick: the measured pose (x, y, theta), the reference's poses and world velocities
 * (dx, dy, dtheta per second) at the stage times t + MPC_STAGE_OFFSETS, each 3 x
 * (MPC_N + 1) with a stage's three numbers together; writes out (MPC_OUT_SIZE numbers) and
 * returns the status. No allocation. (Time mode; in path mode, mpc_tick_path_step calls it
 * with the model's parameter vector and the progress bounds: use the mpc_tick_path_* calls
 * below.) */
int mpc_tick_step(mpc_tick* tick, const double* pose, const double* ref_poses,
                  const double* ref_velocities, double* out);
int mpc_tick_output_size(void);
/* Swerve (MPC_STEER > 0): the modules' steer angles now [rad] (MPC_STEER), e.g. measured;
 * each step starts from the angles the last one commanded unless set here. Powered
 * casters: the measured angles, set before every step (their angles are the robot's state;
 * out[MPC_OUT_STEER] is them plus the steer rates to send times MPC_DT). */
void mpc_tick_set_steer_angles(mpc_tick* tick, const double* angles);
/* The row screen (a tick built with one, MPC_SCREEN_ROWS > 0, e.g. a motor model's rows):
 * rows no plan has had active for ``after`` ticks leave daqp's problem, checked after each
 * solve and solved again with those a plan breaks (the same optimum); 0: every row in
 * daqp's problem. mpc_tick_init sets MPC_SCREEN_AFTER. Forgets the plan's active set. */
void mpc_tick_set_screen(mpc_tick* tick, int after);
/* The row screen's counts (2): rows in daqp's last problem, solves again so far. */
void mpc_tick_screen_counts(const mpc_tick* tick, long* counts);
/* Path mode's warm-up: solve the tick just stepped again (its plan, unshifted, is the
 * guess; the last command and the fallback's memory as before it). */
void mpc_tick_again(mpc_tick* tick);
#if MPC_PROGRESS > 0
/* Path mode (MPC_PROGRESS = N + 1), a tick in three calls: the reference is sampled where
 * the progress is, which the last plan decides.
 *   mpc_tick_path_times(tick, t, times);            the times [s] to sample at (N + 1)
 *   (sample the reference's poses, world velocities and accelerations at those times)
 *   mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
 *   while (mpc_tick_path_again(tick, times)) {      the warm-up after a start with no plan
 *     (sample at the new times; if that fails, stop: the last step's command stands)
 *     mpc_tick_path_step(tick, pose, poses, velocities, accelerations, out);
 *   }
 * then send out's command. t [s] is the tick's time; poses (x, y, theta) [m, m, rad],
 * velocities (dx, dy, dtheta per second of the reference's own time) and accelerations
 * (per second squared), world frame, 3 x (N + 1) each, a stage's three numbers together
 * (NaN where it cannot be sampled: the fallback). out[MPC_OUT_PROGRESS] is the planned
 * progress [s] (its first value: the reference time tracked now). No allocation. */
void mpc_tick_path_times(mpc_tick* tick, double t, double* times);
int mpc_tick_path_step(mpc_tick* tick, const double* pose, const double* poses,
                       const double* velocities, const double* accelerations, double* out);
int mpc_tick_path_again(mpc_tick* tick, double* times);
#endif

#ifdef __cplusplus
}
#endif

#endif
