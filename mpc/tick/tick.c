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
 * finish also gives the feedforward. A row screen (MPC_SCREEN_ROWS > 0, mpc/tick/screen.py:
 * a motor model's rows, swerve's guard faces): daqp gets only the rows in play, each plan
 * checked against the rest and solved again with those it breaks. */
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

#ifndef MPC_SCREEN_ROWS
#define MPC_SCREEN_ROWS 0
#endif
#if MPC_SCREEN_ROWS
/* The row screen (mpc/tick/screen.py): a stage's rows by their place in it (MPC_SCREEN_ROWS
 * places, each stage alike: the plan shifts a stage a tick) leave daqp's problem once no
 * plan has had them active for ``after`` ticks; a plan is checked against the rows left
 * out and solved again with those it breaks (every row after MPC_SCREEN_ROUNDS rounds), so
 * the optimum is the same. daqp gets only the rows in play (its own m set to their count:
 * its buffers were sized for every row). MPC_SCREEN_PLACES: each place's kind, 0 always
 * in play, 1 in play until unneeded, 2 out until a plan breaks it (swerve's guard faces). */
#define MPC_SCREEN_ROUNDS 2
#define MPC_SCREEN_ROUNDING 1e-9 /* as mpc.robots.limits.ROUNDING */
struct mpc_screen {
  int after;                             /* ticks unneeded before a row leaves; 0: off */
  long ticks;                            /* ticks solved so far */
  long again;                            /* solves again with rows a plan broke, so far */
  long needed_at[MPC_SCREEN_ROWS];       /* the tick a plan last had the place active */
  unsigned char in_play[MPC_SCREEN_ROWS];
  int picked[MPC_M], count;              /* daqp's rows (the solver's row numbers) */
  int flags[MPC_M];                      /* daqp's flags of every row between solves */
  double rows[MPC_M * MPC_NV], lower[MPC_M], upper[MPC_M]; /* daqp's rows, whitened */
  int sense[MPC_M];
  int row_start[MPC_M + 1], row_column[MPC_MOVING_ROWS], row_entry[MPC_MOVING_ROWS];
};
#endif

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
#if MPC_SCREEN_ROWS
  struct mpc_screen screen; /* the rows out of daqp's problem (row screen, below) */
#endif
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


#if MPC_SCREEN_ROWS /* (below, with the moving rows) */
static void screen_index(struct mpc_screen* s);
static void screen_reset(struct mpc_screen* s);
static void whiten_row(const struct mpc_screen* s, const double* inverse,
                       const double* values, int row, double* out);
#endif

int mpc_tick_output_size(void) { return MPC_OUT_SIZE; }

/* daqp with no active row: the next solve starts cold. */
static void qp_cold(mpc_tick* t) {
  memset(t->sense, 0, sizeof(t->sense));
  t->qp_cold = 1;
}

/* The active set and the kept Hessian dropped (the Python tick's solver.reset()); every
 * screened place back where it starts. */
static void forget(mpc_tick* t) {
  qp_cold(t);
  t->kept = 0;
#if MPC_SCREEN_ROWS
  screen_reset(&t->screen);
#endif
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
#if MPC_SCREEN_ROWS
  screen_index(&t->screen);
  t->screen.after = MPC_SCREEN_AFTER;
#endif
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

/* The row screen (MPC_SCREEN_ROWS > 0): rows leave daqp's problem after ``after`` ticks
 * unneeded; 0 (or a tick with no screen): every row in daqp's problem. Set before the
 * first step (or after a reset). */
void mpc_tick_set_screen(mpc_tick* t, int after) {
#if MPC_SCREEN_ROWS
  t->screen.after = after > 0 ? after : 0;
  forget(t);
  t->qp.m = t->work.m = MPC_M; /* every row, as mpc_tick_init set daqp up */
  t->qp.A = t->rows;
  t->qp.blower = t->lower;
  t->qp.bupper = t->upper;
  t->qp.sense = t->sense;
#else
  (void)t;
  (void)after;
#endif
}

/* The row screen's counts: rows in daqp's last problem, solves again with rows a plan broke
 * so far (every row and 0 with no screen). */
void mpc_tick_screen_counts(const mpc_tick* t, long* counts) {
#if MPC_SCREEN_ROWS
  counts[0] = t->screen.after > 0 ? t->screen.count : MPC_M;
  counts[1] = t->screen.again;
#else
  (void)t;
  counts[0] = MPC_M;
  counts[1] = 0;
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

#if MPC_SCREEN_ROWS
#if !MPC_MOVING_ROWS
#error "the row screen takes the rows prepare gives (MPC_MOVING_ROWS)"
#endif
#define MPC_SCREENED_ROWS (MPC_N * MPC_SCREEN_ROWS) /* rows after these are always in */

/* The rows' nonzeros by row (prepare gives them column by column), columns ascending in a
 * row: a row whitened alone sums as mpc_tick_whiten_moving does. */
static void screen_index(struct mpc_screen* s) {
  int count[MPC_M + 1], c, k;
  memset(count, 0, sizeof(count));
  for (k = 0; k < MPC_MOVING_ROWS; k++) count[rows_row[k] + 1]++;
  s->row_start[0] = 0;
  for (k = 0; k < MPC_M; k++) s->row_start[k + 1] = s->row_start[k] + count[k + 1];
  memcpy(count, s->row_start, sizeof(int) * MPC_M);
  for (c = 0; c < MPC_NV; c++)
    for (k = rows_colind[c]; k < rows_colind[c + 1]; k++) {
      const int at = count[rows_row[k]]++;
      s->row_column[at] = c;
      s->row_entry[at] = k;
    }
}

/* Every place back where it starts (in play; a guard out), needed as of now (a reset, a
 * failed tick). */
static const unsigned char screen_kind[MPC_SCREEN_ROWS] = MPC_SCREEN_PLACES;

static void screen_reset(struct mpc_screen* s) {
  int p;
  for (p = 0; p < MPC_SCREEN_ROWS; p++) {
    s->in_play[p] = screen_kind[p] != 2;
    s->needed_at[p] = s->ticks;
  }
  memset(s->flags, 0, sizeof(s->flags));
}

/* Row ``row`` in whitened steps into ``out`` (MPC_NV numbers): its nonzeros ``values`` times
 * L^{-1}'s columns (packed), as mpc_tick_whiten_moving sums them. */
static void whiten_row(const struct mpc_screen* s, const double* inverse,
                       const double* values, int row, double* out) {
  int e, i;
  memset(out, 0, sizeof(double) * MPC_NV);
  for (e = s->row_start[row]; e < s->row_start[row + 1]; e++) {
    const int c = s->row_column[e];
    const double* column = inverse + c * MPC_NV - c * (c - 1) / 2; /* L^{-1}[c.., c] */
    const double a = values[s->row_entry[e]];
    double* to = out + c;
    for (i = 0; i < MPC_NV - c; i++) to[i] += a * column[i];
  }
}

static int in_play(const struct mpc_screen* s, int row) {
  return row >= MPC_SCREENED_ROWS || s->in_play[row % MPC_SCREEN_ROWS];
}

/* Row ``r`` as daqp's row ``j``: whitened (a moving row from this tick's values, another
 * from the kept whitened rows), its bounds. */
static void screen_put(mpc_tick* t, int r, int j) {
  struct mpc_screen* s = &t->screen;
  if (rows_move[r])
    whiten_row(s, t->inverse, t->row_values, r, s->rows + j * MPC_NV);
  else
    memcpy(s->rows + j * MPC_NV, t->rows + r * MPC_NV, sizeof(double) * MPC_NV);
  s->picked[j] = r;
  s->lower[j] = t->lower[r];
  s->upper[j] = t->upper[r];
}

/* daqp's rows: those in play, whitened (moving rows from this tick's values, the others
 * from the kept whitened rows), their bounds and their flags from the last solve. */
static void screen_pick(mpc_tick* t) {
  struct mpc_screen* s = &t->screen;
  int r, j = 0;
  for (r = 0; r < MPC_M; r++) {
    if (in_play(s, r)) screen_put(t, r, j++);
  }
  s->count = j;
}

/* The rows of place ``p`` (out of play) put in play, after daqp's rows (the rows already
 * there stay whitened). */
static void screen_admit(mpc_tick* t, int p) {
  struct mpc_screen* s = &t->screen;
  int k;
  s->in_play[p] = 1;
  s->needed_at[p] = s->ticks;
  for (k = 0; k < MPC_N; k++) {
    screen_put(t, k * MPC_SCREEN_ROWS + p, s->count++);
  }
}

/* The places out of play whose rows the step ``t->step`` breaks at some stage beyond
 * rounding (marked in ``broken``); how many. */
static int screen_broken(mpc_tick* t, unsigned char* broken) {
  const struct mpc_screen* s = &t->screen;
  double largest = 1.0, slack;
  int p, k, e, found = 0;
  for (p = 0; p < MPC_SCREEN_ROWS; p++) {
    broken[p] = 0;
    if (s->in_play[p]) continue;
    for (k = 0; k < MPC_N; k++) {
      const int r = k * MPC_SCREEN_ROWS + p;
      if (isfinite(t->lower[r]) && fabs(t->lower[r]) > largest) largest = fabs(t->lower[r]);
      if (isfinite(t->upper[r]) && fabs(t->upper[r]) > largest) largest = fabs(t->upper[r]);
    }
  }
  slack = MPC_SCREEN_ROUNDING * largest;
  for (p = 0; p < MPC_SCREEN_ROWS; p++) {
    if (s->in_play[p]) continue;
    for (k = 0; k < MPC_N && !broken[p]; k++) {
      const int r = k * MPC_SCREEN_ROWS + p;
      double value = 0.0;
      for (e = s->row_start[r]; e < s->row_start[r + 1]; e++)
        value += t->row_values[s->row_entry[e]] * t->step[s->row_column[e]];
      if (value - t->upper[r] > slack || t->lower[r] - value > slack) broken[p] = 1;
    }
    found += broken[p];
  }
  return found;
}

/* Places no plan has needed for ``after`` ticks leave (never one with an equality row: every
 * plan is on it; one stays if all would go). */
static void screen_retire(mpc_tick* t) {
  struct mpc_screen* s = &t->screen;
  unsigned char stale[MPC_SCREEN_ROWS];
  int p, k, left = 0, any = 0, keep = -1;
  for (p = 0; p < MPC_SCREEN_ROWS; p++) {
    stale[p] = s->in_play[p] && screen_kind[p] && s->ticks - s->needed_at[p] >= s->after;
    for (k = 0; k < MPC_N && stale[p]; k++)
      if (t->lower[k * MPC_SCREEN_ROWS + p] == t->upper[k * MPC_SCREEN_ROWS + p]) stale[p] = 0;
    any += stale[p];
    left += s->in_play[p] && !stale[p];
    if (s->in_play[p] && (keep < 0 || s->needed_at[p] > s->needed_at[keep])) keep = p;
  }
  if (!any) return;
  if (!left) stale[keep] = 0; /* daqp needs a row: the last one needed stays */
  for (p = 0; p < MPC_SCREEN_ROWS; p++)
    if (stale[p]) s->in_play[p] = 0;
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
#elif MPC_STEER
  t->arg[7] = t->steer; /* axle-offset modules (mpc/tick/offset.py): constant rows */
  t->arg[8] = 0;        /* (no rows' state: an empty input) */
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
#if MPC_SCREEN_ROWS
    if (t->screen.after > 0) { /* screen_pick whitens daqp's rows; here the fixed ones */
      int r;
      if (t->rebuilt)
        for (r = 0; r < MPC_M; r++)
          if (!rows_move[r])
            whiten_row(&t->screen, t->inverse, t->row_values, r, t->rows + r * MPC_NV);
    } else
#endif
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

#if MPC_SCREEN_ROWS
static int solve_screened(mpc_tick* t, double* iterations, double* seconds);
#endif

/* daqp on the rows prepare wrote: its exit flag (the step in t->y). */
static int solve(mpc_tick* t, double* iterations, double* seconds) {
  int i, flag, mask = UPDATE_v + UPDATE_d, equalities = 0;
#if MPC_SCREEN_ROWS
  if (t->screen.after > 0) return solve_screened(t, iterations, seconds);
#endif
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

/* The step d = L^{-T} y (unwhiten). */
static void unwhiten(mpc_tick* t) {
  t->arg[0] = t->inverse;
  t->arg[1] = t->y;
  t->out[0] = t->step;
  mpc_tick_unwhiten(t->arg, t->out, t->iw, t->w, 0);
}

#if MPC_SCREEN_ROWS
/* daqp on the rows in play (screen_pick), warm from their flags; its exit flag (the
 * step in t->y), the flags of its rows saved. ``limit``: its iteration limit. */
static int solve_picked(mpc_tick* t, int limit, double* iterations, double* seconds) {
  struct mpc_screen* s = &t->screen;
  int i, flag, mask = UPDATE_v + UPDATE_d + UPDATE_M + UPDATE_sense, warm = 0, equalities = 0;
  t->qp.m = t->work.m = s->count;
  t->qp.A = s->rows;
  t->qp.blower = s->lower;
  t->qp.bupper = s->upper;
  t->qp.sense = s->sense;
  for (i = 0; i < s->count; i++) {
    s->sense[i] = s->flags[s->picked[i]];
    if (s->lower[i] == s->upper[i]) {
      s->sense[i] = MPC_EQUALITY;
      equalities = 1;
    }
    warm |= s->sense[i] & ACTIVE;
  }
  t->work.settings->iter_limit = limit;
  reset_daqp_workspace(&t->work);
  flag = update_ldp(mask, &t->work);
  if (flag >= 0 && warm && activate_constraints(&t->work) < 0) {
    /* the kept active set does not fit the new rows: start cold */
    for (i = 0; i < s->count; i++)
      s->sense[i] = s->lower[i] == s->upper[i] ? MPC_EQUALITY : 0;
    reset_daqp_workspace(&t->work);
    flag = update_ldp(mask, &t->work);
    if (flag >= 0 && equalities && activate_constraints(&t->work) < 0) flag = -1;
  }
  t->qp_cold = 0;
  if (flag < 0) {
    for (i = 0; i < MPC_NV; i++) t->y[i] = NAN;
    return flag;
  }
  daqp_solve(&t->res, &t->work);
  *iterations += t->res.iter;
  *seconds += t->res.solve_time + t->res.setup_time;
  for (i = 0; i < s->count; i++)
    s->flags[s->picked[i]] = t->work.sense[i] & (ACTIVE | LOWER | IMMUTABLE);
  return t->res.exitflag;
}

/* The tick solved with the rows in play, checked against the rows left out and solved
 * again with those its plan breaks (every row after MPC_SCREEN_ROUNDS rounds); with a
 * budget, the solves share its iterations. The places the plan has active are needed as
 * of this tick; then the places unneeded for ``after`` ticks leave. The step in t->step. */
static int solve_screened(mpc_tick* t, double* iterations, double* seconds) {
  struct mpc_screen* s = &t->screen;
  unsigned char broken[MPC_SCREEN_ROWS];
  int flag, rounds = 0, i, p;
  if (t->qp_cold) memset(s->flags, 0, sizeof(s->flags));
  s->ticks++;
  screen_pick(t);
  for (;;) {
    const int used = (int)*iterations;
    const int limit = t->budgeted ? t->max_iter - used : t->max_iter;
    if (limit <= 0) {
      flag = EXIT_ITERLIMIT;
      for (i = 0; i < MPC_NV; i++) t->y[i] = NAN;
      break;
    }
    flag = solve_picked(t, limit, iterations, seconds);
    unwhiten(t);
    if (!(flag > 0 && finite_vector(t->step, MPC_NV))) break;
    for (i = 0; i < s->count; i++)
      if (s->picked[i] < MPC_SCREENED_ROWS && (t->work.sense[i] & ACTIVE))
        s->needed_at[s->picked[i] % MPC_SCREEN_ROWS] = s->ticks;
    if (!screen_broken(t, broken)) break;
    rounds++;
    s->again++;
    for (p = 0; p < MPC_SCREEN_ROWS; p++)
      if (!s->in_play[p] && (broken[p] || rounds > MPC_SCREEN_ROUNDS)) screen_admit(t, p);
  }
  t->work.settings->iter_limit = t->max_iter;
  if (flag > 0) screen_retire(t);
  return flag;
}
#endif

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
  unwhiten(t);
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
