/* The compiled tick's hand-written part: daqp's workspace kept between ticks and a dense
 * Cholesky factor, around the generated graphs (mpc_tick_prepare, mpc_tick_hessian,
 * mpc_tick_whiten, mpc_tick_whiten_rows, mpc_tick_unwhiten, mpc_tick_finish;
 * mpc/tick/graphs.py).
 *
 * The Hessian, its factor, L^{-1} and the whitened rows are kept across ticks and rebuilt
 * when prepare's drift exceeds the rebuild threshold or nothing is kept (the rule of
 * mpc/tick/reuse.py); a tick that keeps them hands daqp only a new gradient and bounds.
 * daqp is set up once (Hessian the identity: the graphs hand it whitened rows), and each
 * tick gets its updates (update_ldp) and its last active set back (activate_constraints):
 * a warm start, with no allocation after mpc_tick_init. A failed
 * tick drops the active set (the Python path's solver.reset()); a tick that failed from
 * the cold guess is solved once more from the last command held, unless a budget was
 * given (the Python controller's rule). Everything the caller needs comes out in one
 * array, the status included (a non-optimal QP never loses it).
 *
 * Rows that move every tick (MPC_MOVING_ROWS > 0: swerve's speed faces, a motor model's
 * rows, mpc/tick/steered.py and motors.py): prepare gives their nonzeros, whitened every
 * tick with the kept L^{-1} and handed to daqp every tick. A motor model (MPC_FF > 0):
 * finish also gives the feedforward. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <daqp/api.h>
#include <daqp/utils.h>

#include "mpc_tick.h"
#include "mpc_tick_graphs.h"

#define MPC_COLD 0.0
#define MPC_WARM 1.0
#define MPC_HOLD 2.0
#define MPC_UNPLANNED (-1000.0)
/* daqp's flag of an equality row (active, immutable): a row whose bounds are equal */
#define MPC_EQUALITY 5

struct mpc_tick {
  /* state carried between ticks */
  double last[3];
  double plan[3 * MPC_N];
  double memory[2]; /* failures in a row, whether a plan is kept */
  int warm;         /* the last tick solved: its plan is the next guess */
  int qp_cold;      /* daqp starts from an empty active set */
  int max_iter, budgeted;
  double rebuild_drift; /* rebuild above this drift (below 0: every tick) */
  int kept;             /* a Hessian (factor, inverse, whitened rows) is kept */
  int rebuilt;          /* this tick rebuilt it (daqp gets the new rows) */
  double kept_terms[MPC_TERMS], terms[MPC_TERMS], drift;
  /* prepare's and whiten's outputs (daqp reads f, rows, bounds in place) */
  double hessian[MPC_NV * MPC_NV], gradient[MPC_NV], factor[MPC_NV * MPC_NV];
  double inverse[MPC_NV * (MPC_NV + 1) / 2]; /* L^{-1}, its lower triangle packed */
  double f[MPC_NV], rows[MPC_NV * MPC_M], lower[MPC_M], upper[MPC_M], carry[MPC_CARRY];
  double eye[MPC_NV * MPC_NV];
  int sense[MPC_M];
  double y[MPC_NV], lam[MPC_M], step[MPC_NV];
  /* finish's outputs */
  double status, twist[3], speeds[MPC_W], clamped, poses[3 * (MPC_N + 1)];
  double plan_next[3 * MPC_N], memory_next[2];
  double mode;
#if MPC_MOVING_ROWS
  /* the rows prepare gives every tick (nonzeros); swerve: the faces' directions (a motor
   * model has no such state: 1, no empty arrays) */
  double row_values[MPC_MOVING_ROWS];
  double state[MPC_ROW_STATE > 0 ? MPC_ROW_STATE : 1];
  double state_next[MPC_ROW_STATE > 0 ? MPC_ROW_STATE : 1];
#endif
#if MPC_STEER
  double steer[MPC_STEER], steer_next[MPC_STEER]; /* the modules' angles [rad] */
#endif
  /* path mode: the planned progress; a tick solved again (mpc_tick_again) takes the last
   * round's plan unshifted, with the last command and memory from before the tick */
  double progress[MPC_PROGRESS > 0 ? MPC_PROGRESS : 1];
  double feedforward[MPC_FF > 0 ? MPC_FF : 1]; /* a motor model's (MPC_FF numbers) */
  int again;
  double last_before[3], memory_before[2];
#if MPC_PROGRESS > 0
  /* path mode's progress between ticks (mpc_tick_path_times, _step, _again; the Python
   * tick's PathProgress): the last plan's progress (or the guess of a failed tick), the
   * guess of this tick and the last one sampled, the reference and bounds made of the
   * samples; the last tick's time, the warm-up's rounds left, whether the last step
   * solved, whether the next step is a round of the warm-up */
  double path_plan[MPC_PROGRESS], path_guess[MPC_PROGRESS], path_sampled[MPC_PROGRESS];
  double path_reference[MPC_REF_SIZE], path_bounds[MPC_REF2_SIZE];
  double path_t, path_previous;
  int path_has_plan, path_has_previous, path_rounds, path_solved, path_pending;
#endif
  DAQPProblem qp;
  DAQPWorkspace work;
  DAQPResult res;
  /* the graphs' work arrays */
  const double* arg[MPC_SZ_ARG];
  double* out[MPC_SZ_RES];
  casadi_int iw[MPC_SZ_IW];
  double w[MPC_SZ_W];
};


int mpc_tick_output_size(void) { return MPC_OUT_SIZE; }

/* daqp with no active row: the next solve starts cold. */
static void qp_cold(mpc_tick* t) {
  memset(t->sense, 0, sizeof(t->sense));
  t->qp_cold = 1;
}

/* The active set and the kept Hessian dropped (the Python tick's solver.reset()). */
static void forget(mpc_tick* t) {
  qp_cold(t);
  t->kept = 0;
}

mpc_tick* mpc_tick_init(int max_iter, int budgeted, double rebuild_drift) {
  mpc_tick* t = (mpc_tick*)calloc(1, sizeof(mpc_tick));
  int i;
  c_float setup_time = 0;
  if (!t) return NULL;
  t->max_iter = max_iter;
  t->budgeted = budgeted;
  t->rebuild_drift = rebuild_drift;
  for (i = 0; i < MPC_NV; i++) t->eye[i * MPC_NV + i] = 1.0;
  /* A benign problem to set daqp up with (unit rows, bounds -1..1): every buffer it
   * allocates is allocated now, once. */
  for (i = 0; i < MPC_M; i++) {
    t->rows[i * MPC_NV + i % MPC_NV] = 1.0;
    t->lower[i] = -1.0;
    t->upper[i] = 1.0;
  }
  t->qp.n = MPC_NV;
  t->qp.m = MPC_M;
  t->qp.ms = 0;
  t->qp.H = t->eye;
  t->qp.f = t->f;
  t->qp.A = t->rows;
  t->qp.bupper = t->upper;
  t->qp.blower = t->lower;
  t->qp.sense = t->sense;
  t->res.x = t->y;
  t->res.lam = t->lam;
  if (setup_daqp(&t->qp, &t->work, &setup_time) < 0) {
    free(t);
    return NULL;
  }
  t->work.settings->iter_limit = max_iter;
#if MPC_MOVING_ROWS && MPC_ROW_STATE
  {
    static const double start[MPC_ROW_STATE] = MPC_ROW_STATE_START;
    memcpy(t->state, start, sizeof(t->state));
  }
#endif
  forget(t);
  return t;
}

void mpc_tick_set_steer_angles(mpc_tick* t, const double* angles) {
#if MPC_STEER
  memcpy(t->steer, angles, sizeof(t->steer));
#else
  (void)t;
  (void)angles;
#endif
}

void mpc_tick_free(mpc_tick* t) {
  if (!t) return;
  free_daqp_workspace(&t->work);
  free_daqp_ldp(&t->work);
  free(t);
}

/* Forget the plan, the failures, the active set and the kept Hessian; ``last`` is the twist the robot is
 * executing [m/s, m/s, rad/s]. */
void mpc_tick_reset(mpc_tick* t, const double* last) {
  memcpy(t->last, last, sizeof(t->last));
  memset(t->plan, 0, sizeof(t->plan));
  t->memory[0] = t->memory[1] = 0.0;
  t->warm = 0;
  forget(t);
#if MPC_PROGRESS > 0
  t->path_has_plan = t->path_has_previous = t->path_rounds = 0;
  t->path_solved = t->path_pending = 0;
#endif
}

/* L with H = L L' (lower, column-major: a column's entries together) from H's lower
 * triangle, right-looking: each column scaled, then subtracted from the columns after it
 * (independent updates the compiler can pipeline, not one chain of sums); 0 if a pivot is
 * not positive. The upper half of ``l`` is not written. */
static int cholesky_once(const double* h, double shift, double* l) {
  int i, j, k;
  for (j = 0; j < MPC_NV; j++)
    for (i = j; i < MPC_NV; i++) l[i + MPC_NV * j] = h[i + MPC_NV * j];
  for (j = 0; j < MPC_NV; j++) {
    double* column = l + MPC_NV * j;
    double pivot = column[j] + shift;
    if (!(pivot > 0.0)) return 0;
    pivot = sqrt(pivot);
    column[j] = pivot;
    for (i = j + 1; i < MPC_NV; i++) column[i] /= pivot;
    for (k = j + 1; k < MPC_NV; k++) {
      double* later = l + MPC_NV * k;
      const double factor = column[k];
      for (i = k; i < MPC_NV; i++) later[i] -= column[i] * factor;
    }
  }
  return 1;
}

/* X = L^{-1} of a lower-triangular L (column-major), its lower triangle packed column by
 * column (column j: rows j .. n-1), as CasADi reads a lower-triangular matrix: each
 * column by forward substitution in axpy form (independent updates). */
static void lower_inverse(const double* l, double* x) {
  double column[MPC_NV];
  int i, j, k, at = 0;
  for (j = 0; j < MPC_NV; j++) {
    for (i = j; i < MPC_NV; i++) column[i] = 0.0;
    column[j] = 1.0;
    for (k = j; k < MPC_NV; k++) {
      const double* lk = l + MPC_NV * k;
      const double value = column[k] / lk[k];
      column[k] = value;
      for (i = k + 1; i < MPC_NV; i++) column[i] -= lk[i] * value;
    }
    for (i = j; i < MPC_NV; i++) x[at++] = column[i];
  }
}

#if MPC_MOVING_ROWS
static const int rows_colind[MPC_NV + 1] = MPC_ROWS_COLIND;
static const int rows_row[MPC_MOVING_ROWS] = MPC_ROWS_ROW;
static const unsigned char rows_move[MPC_M] = MPC_ROWS_MOVE;

/* The moving rows in whitened steps (swerve's, a motor model's), A L^{-T} row-major as daqp reads them, from A's
 * nonzeros (``values``, column by column: prepare's ``rows``) and L^{-1} (packed column by
 * column): mpc_tick_whiten_rows' arithmetic, each entry summed in the same order, as
 * axpys along L^{-1}'s columns; every row (``every``: a new L^{-1}) or only the rows that
 * move (the speed faces; ``rows`` holds the others, whitened by this L^{-1}). The rows move
 * every tick, and the generated sparse product took about 0.5 ms a call at N = 20
 * (docs/guide/compiled-tick.md, "Swerve"); this loop is tested against it
 * (tests/test_compiled_swerve.py). */
void mpc_tick_whiten_moving(const double* inverse, const double* values, double* rows,
                            int every);
void mpc_tick_whiten_moving(const double* inverse, const double* values, double* rows,
                            int every) {
  int c, k, i, start = 0;
  for (i = 0; i < MPC_M; i++)
    if (every || rows_move[i]) memset(rows + i * MPC_NV, 0, sizeof(double) * MPC_NV);
  for (c = 0; c < MPC_NV; c++) {
    const double* column = inverse + start; /* L^{-1}[c.., c] */
    const int length = MPC_NV - c;
    for (k = rows_colind[c]; k < rows_colind[c + 1]; k++) {
      double* out;
      if (!every && !rows_move[rows_row[k]]) continue;
      out = rows + rows_row[k] * MPC_NV + c;
      const double a = values[k];
      for (i = 0; i < length; i++) out[i] += a * column[i];
    }
    start += length;
  }
}
#endif

/* The factor, regularised as the Python path regularises a Hessian that is not positive
 * definite (1e-9 of its trace on the diagonal); NaN if that fails too (the QP fails). */
static void cholesky(const double* h, double* l) {
  double trace = 0.0;
  int i;
  if (cholesky_once(h, 0.0, l)) return;
  for (i = 0; i < MPC_NV; i++) trace += h[i + MPC_NV * i];
  if (cholesky_once(h, 1e-9 * trace, l)) return;
  for (i = 0; i < MPC_NV * MPC_NV; i++) l[i] = NAN;
}

/* prepare; then, if the rule says so (planned: the reference could be sampled), the
 * Hessian, its factor, L^{-1} and the whitened rows rebuilt; the gradient whitened. */
static void prepare(mpc_tick* t, const double* pose, const double* ref_poses,
                    const double* ref_velocities, double mode, int planned) {
  t->mode = mode;
  t->arg[0] = pose;
  t->arg[1] = ref_poses;
  t->arg[2] = ref_velocities;
  t->arg[3] = t->last;
  t->arg[4] = t->plan;
  t->arg[5] = &t->mode;
  t->arg[6] = t->kept_terms;
  t->out[0] = t->gradient;
  t->out[1] = t->lower;
  t->out[2] = t->upper;
  t->out[3] = t->carry;
  t->out[4] = t->terms;
  t->out[5] = &t->drift;
#if MPC_MOVING_ROWS
#if MPC_STEER
  t->arg[7] = t->steer;
#else
  t->arg[7] = 0; /* (no steer angles: an empty input) */
#endif
  t->arg[8] = t->state;
  t->out[6] = t->row_values;
  t->out[7] = t->state_next;
#endif
  mpc_tick_prepare(t->arg, t->out, t->iw, t->w, 0);
#if MPC_MOVING_ROWS
  /* the faces' directions turned to this guess (not on a tick with no reference) */
  if (planned) memcpy(t->state, t->state_next, sizeof(t->state));
#endif
  /* the rule (mpc/tick/reuse.py, must_rebuild): nothing kept, or moved too far */
  t->rebuilt = planned && (!t->kept || t->drift > t->rebuild_drift);
  if (t->rebuilt) {
    t->arg[0] = t->carry;
    t->out[0] = t->hessian;
    mpc_tick_hessian(t->arg, t->out, t->iw, t->w, 0);
    cholesky(t->hessian, t->factor);
    lower_inverse(t->factor, t->inverse);
    memcpy(t->kept_terms, t->terms, sizeof(t->kept_terms));
    t->kept = 1;
  }
  if (t->rebuilt || (MPC_MOVING_ROWS && planned)) { /* moving rows: every tick */
#if MPC_MOVING_ROWS
    mpc_tick_whiten_moving(t->inverse, t->row_values, t->rows, t->rebuilt);
#else
    t->arg[0] = t->inverse;
    t->out[0] = t->rows;
    mpc_tick_whiten_rows(t->arg, t->out, t->iw, t->w, 0);
#endif
  }
  t->arg[0] = t->inverse;
  t->arg[1] = t->gradient;
  t->out[0] = t->f;
  mpc_tick_whiten(t->arg, t->out, t->iw, t->w, 0);
}

/* A cold start's sense: rows whose bounds are equal (path mode's first progress) active
 * and immutable, as the Python tick's daqp set-up marks them; how many. */
static int cold_sense(mpc_tick* t) {
  int i, count = 0;
  for (i = 0; i < MPC_M; i++)
    if (t->lower[i] == t->upper[i]) {
      t->sense[i] = MPC_EQUALITY;
      count++;
    }
  return count;
}

/* daqp on the rows prepare wrote: its exit flag (the step in t->y). */
static int solve(mpc_tick* t, double* iterations, double* seconds) {
  int i, flag, mask = UPDATE_v + UPDATE_d, equalities = 0;
  if (t->rebuilt || MPC_MOVING_ROWS) mask += UPDATE_M; /* new whitened rows */
  if (t->qp_cold) { /* sense from t->sense: all inactive but the equalities */
    mask += UPDATE_sense;
    equalities = cold_sense(t);
  }
  reset_daqp_workspace(&t->work);
  flag = update_ldp(mask, &t->work);
  if (flag >= 0 && (!t->qp_cold || equalities) && activate_constraints(&t->work) < 0) {
    /* the kept active set does not fit the new rows: start cold */
    qp_cold(t);
    equalities = cold_sense(t);
    reset_daqp_workspace(&t->work);
    flag = update_ldp(mask | UPDATE_sense, &t->work);
    if (flag >= 0 && equalities && activate_constraints(&t->work) < 0)
      flag = -1; /* the equalities alone do not fit: the tick fails (daqp's infeasible) */
  }
  t->qp_cold = 0;
  if (flag < 0) {
    for (i = 0; i < MPC_NV; i++) t->y[i] = NAN;
    return flag;
  }
  daqp_solve(&t->res, &t->work);
  *iterations += t->res.iter;
  *seconds += t->res.solve_time + t->res.setup_time;
  return t->res.exitflag;
}

static int finite_vector(const double* x, int n) {
  double sum = 0.0;
  int i;
  for (i = 0; i < n; i++) sum += x[i];
  return isfinite(sum);
}

/* One tick: from the measured pose and the reference window (poses and world velocities
 * at the stage times, 3 x (N+1) column-major: a stage's three numbers together) to the
 * command, the plan and the status (``out``, mpc_tick_output_size() numbers). */
int mpc_tick_step(mpc_tick* t, const double* pose, const double* ref_poses,
                  const double* ref_velocities, double* out) {
  double iterations = 0.0, seconds = 0.0, flag;
  int cold = !t->warm && !t->again, i, rebuilt;
  int planned = finite_vector(ref_poses, MPC_REF_SIZE) &&
                finite_vector(ref_velocities, MPC_REF2_SIZE);
  double mode = t->again ? MPC_AGAIN_MODE : cold ? MPC_COLD : MPC_WARM;
  t->again = 0;
  memcpy(t->last_before, t->last, sizeof(t->last));
  memcpy(t->memory_before, t->memory, sizeof(t->memory));
  prepare(t, pose, ref_poses, ref_velocities, mode, planned);
  rebuilt = t->rebuilt;
  if (!planned) {
    flag = MPC_UNPLANNED; /* no QP: the fallback without the feedforward */
    for (i = 0; i < MPC_NV; i++) t->y[i] = NAN;
  } else {
    flag = solve(t, &iterations, &seconds);
    if (!(flag > 0 && finite_vector(t->y, MPC_NV)) && cold && !t->budgeted) {
      forget(t); /* solve again from the last command held (a Hessian of its own) */
      prepare(t, pose, ref_poses, ref_velocities, MPC_HOLD, planned);
      rebuilt += t->rebuilt;
      flag = solve(t, &iterations, &seconds);
    }
  }
  t->arg[0] = t->inverse;
  t->arg[1] = t->y;
  t->out[0] = t->step;
  mpc_tick_unwhiten(t->arg, t->out, t->iw, t->w, 0);
  t->arg[0] = t->step;
  t->arg[1] = &flag;
  t->arg[2] = t->carry;
  t->arg[3] = t->last;
  t->arg[4] = t->plan;
  t->arg[5] = t->memory;
  t->out[0] = &t->status;
  t->out[1] = t->twist;
  t->out[2] = t->speeds;
  t->out[3] = &t->clamped;
  t->out[4] = t->poses;
  t->out[5] = t->plan_next;
  t->out[6] = t->memory_next;
#if MPC_STEER
  t->arg[6] = t->steer;
  t->out[7] = t->steer_next;
#elif MPC_PROGRESS > 0
  t->out[7] = t->progress;
#elif MPC_FF > 0
  t->out[7] = t->feedforward;
#endif
  mpc_tick_finish(t->arg, t->out, t->iw, t->w, 0);
  t->warm = t->status == 0.0;
  if (!t->warm) forget(t);
  memcpy(t->last, t->twist, sizeof(t->last));
  memcpy(t->plan, t->plan_next, sizeof(t->plan));
  memcpy(t->memory, t->memory_next, sizeof(t->memory));
#if MPC_STEER
  memcpy(t->steer, t->steer_next, sizeof(t->steer));
  memcpy(out + MPC_OUT_STEER, t->steer, sizeof(t->steer));
#endif
  out[MPC_OUT_STATUS] = t->status;
  out[MPC_OUT_FLAG] = flag;
  out[MPC_OUT_ITERATIONS] = iterations;
  out[MPC_OUT_SOLVE_TIME] = seconds;
  out[MPC_OUT_CLAMPED] = t->clamped;
  out[MPC_OUT_FAILURES] = t->memory[0];
  out[MPC_OUT_REBUILT] = rebuilt;
  memcpy(out + MPC_OUT_TWIST, t->twist, sizeof(t->twist));
  memcpy(out + MPC_OUT_SPEEDS, t->speeds, sizeof(t->speeds));
  memcpy(out + MPC_OUT_POSES, t->poses, sizeof(t->poses));
#if MPC_PROGRESS > 0
  memcpy(out + MPC_OUT_PROGRESS, t->progress, sizeof(double) * MPC_PROGRESS);
#endif
#if MPC_FF > 0
  memcpy(out + MPC_OUT_FEEDFORWARD, t->feedforward, sizeof(double) * MPC_FF);
#endif
  return (int)t->status;
}

/* Path mode's warm-up: the tick just stepped is solved again (its plan, unshifted, the
 * guess; daqp cold; the last command and the fallback's memory as before that tick). */
void mpc_tick_again(mpc_tick* t) {
  memcpy(t->last, t->last_before, sizeof(t->last));
  memcpy(t->memory, t->memory_before, sizeof(t->memory));
  forget(t);
  t->again = 1;
}

#if MPC_PROGRESS > 0
/* Path mode, step 1 of a tick at time ``now`` [s]: the times (MPC_PROGRESS) at which the
 * caller samples the reference this tick (the progress guess: the last plan read on, or on
 * time after a reset or a jump in ``now``; graph mpc_tick_progress_times). */
void mpc_tick_path_times(mpc_tick* t, double now, double* times) {
  double known = t->path_has_plan && t->path_has_previous ? 1.0 : 0.0;
  t->arg[0] = &now;
  t->arg[1] = &t->path_previous;
  t->arg[2] = t->path_plan;
  t->arg[3] = &known;
  t->out[0] = t->path_guess;
  mpc_tick_progress_times(t->arg, t->out, t->iw, t->w, 0);
  t->path_t = t->path_previous = now;
  t->path_has_previous = 1;
  t->path_rounds = t->path_solved ? 0 : MPC_WARM_UP_ROUNDS; /* a warm-up without a plan */
  t->path_pending = 0;
  memcpy(times, t->path_guess, sizeof(t->path_guess));
}

/* Path mode, step 2: the tick (or a warm-up round) with the reference sampled at the times
 * given: its poses, world velocities and accelerations, 3 x MPC_PROGRESS each (a stage's
 * three numbers together; NaN where it cannot be sampled: the fallback). */
int mpc_tick_path_step(mpc_tick* t, const double* pose, const double* poses,
                       const double* velocities, const double* accelerations, double* out) {
  int status;
  if (t->path_pending) mpc_tick_again(t); /* a warm-up round: this tick solved again */
  t->path_pending = 0;
  t->arg[0] = pose;
  t->arg[1] = t->path_guess;
  t->arg[2] = &t->path_t;
  t->arg[3] = poses;
  t->arg[4] = velocities;
  t->arg[5] = accelerations;
  t->out[0] = t->path_reference;
  t->out[1] = t->path_bounds;
  mpc_tick_progress_reference(t->arg, t->out, t->iw, t->w, 0);
  if (finite_vector(poses, 3 * MPC_PROGRESS) && finite_vector(velocities, 3 * MPC_PROGRESS)
      && finite_vector(accelerations, 3 * MPC_PROGRESS))
    memcpy(t->path_sampled, t->path_guess, sizeof(t->path_guess));
  status = mpc_tick_step(t, pose, t->path_reference, t->path_bounds, out);
  /* the plan's progress, or where the reference was last sampled after a failed tick */
  t->path_solved = status == MPC_SOLVED;
  memcpy(t->path_plan, t->path_solved ? t->progress : t->path_sampled, sizeof(t->path_plan));
  t->path_has_plan = 1;
  return status;
}

/* Path mode, step 3 (after a solved step with no plan to start from): 1 and the times of
 * another round of the warm-up (sample there and call mpc_tick_path_step again), 0 once
 * the progress settled or after MPC_WARM_UP_ROUNDS rounds (graph mpc_tick_progress_refine).
 * A caller that cannot sample at the times keeps the last step's command. */
int mpc_tick_path_again(mpc_tick* t, double* times) {
  double settled = 1.0;
  if (!t->path_solved || t->path_rounds <= 0) return 0;
  t->path_rounds--;
  t->arg[0] = t->progress;
  t->arg[1] = t->path_guess;
  t->arg[2] = &t->path_t;
  t->out[0] = &settled;
  t->out[1] = times;
  mpc_tick_progress_refine(t->arg, t->out, t->iw, t->w, 0);
  if (settled != 0.0) return 0;
  memcpy(t->path_guess, times, sizeof(t->path_guess));
  t->path_pending = 1;
  return 1;
}
#endif
