"""A powered caster's limits for the solvers and the clamp, with the steer angles as states.

The joint rates are linear in the twist for given steer angles (see
:mod:`mpc.robots.wheels.caster.robot`)::

    phidot_i  = D_i(beta_i) xi,  D_i = [cos b, sin b, px sin b - py cos b] / r
    betadot_i = S_i(beta_i) xi,  S_i = [-sin b, cos b, px cos b + py sin b - d] / d

and the angles follow the motion: ``d beta_i / dt = S_i(beta_i) xi``. Over a plan of
twists ``u_0 .. u_{N-1}`` (``u_k`` held for ``h_k``) the angles at the stages' starts
``beta_0 .. beta_{N-1}`` come from the measured ones ``beta_0`` by integrating that
ODE (RK4, :func:`substeps` steps a stage: at most one of the caster's fastest time
constants ``d / |v(P)|`` a step for the fast path's prediction, 2.5 in the NLP).

- **Exact path** (IPOPT, :func:`nlp_stage_limits`): the angles are integrated
  symbolically from the measured ones (a parameter), and every stage's drive rate,
  steer rate (and, with an acceleration limit, change of drive rate) is constrained
  at its own ``beta_k(u_0 .. u_{k-1})``, exactly.
- **Fast path** (QP, :func:`update_stage_limits`): each tick the angles are predicted
  along the plan the solver starts from (the shifted last plan), and the rows
  ``D(beta_k) u_k``, ``S(beta_k) u_k`` are filled at those predicted angles: linear in
  ``u_k``, a fixed pattern of three coefficients a row. Stage 0's angles are the
  measured ones, so the command's own rows are exact; later stages' move with the
  plan from tick to tick (real-time iteration on the angles as on the poses).
- **Clamp** (:func:`clamp_at`): at the measured angles the limits are a polytope in
  the twist that contains 0; the command steps from the last one towards the
  solver's as far as every joint limit allows (or, if the last command is outside the
  polytope at the new angles, the solver's is scaled into it).
"""

from __future__ import annotations

import math
import threading

import casadi as ca
import numpy as np

from mpc.arrays import FloatArray
from mpc.buffered import BufferedFunction
from mpc.errors import RobotError
from mpc.robots.limits import StageLimits
from mpc.robots.wheels.caster.geometry import CasterGeometry

#: Relative slack under which a joint counts as within its limit (rounding).
_SLACK = 1e-12


def joint_rows(robot: CasterGeometry, angles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``D`` and ``S`` (each (..., n, 3)) at steer angles (..., n) [rad]."""
    positions = np.asarray(robot.caster_positions)
    px, py = positions[:, 0], positions[:, 1]
    c, s = np.cos(angles), np.sin(angles)
    d, r = robot.offsets, robot.radii
    rows = np.empty((2,) + c.shape + (3,))  # (one array: this runs several times a tick)
    drive, steer = rows[0], rows[1]
    drive[..., 0], drive[..., 1], drive[..., 2] = c / r, s / r, (px * s - py * c) / r
    steer[..., 0], steer[..., 1] = -s / d, c / d
    steer[..., 2] = (px * c + py * s - d) / d
    return drive, steer


def _symbolic_rows(robot: CasterGeometry, angle: ca.SX, i: int) -> tuple[ca.SX, ca.SX]:
    """Caster ``i``'s drive and steer rows (1 x 3) at a symbolic angle."""
    px, py = (float(v) for v in np.asarray(robot.caster_positions)[i])
    d, r = float(robot.offsets[i]), float(robot.radii[i])
    c, s = ca.cos(angle), ca.sin(angle)
    drive = ca.horzcat(c, s, px * s - py * c) / r
    steer = ca.horzcat(-s, c, px * c + py * s - d) / d
    return drive, steer


#: RK4 step of the angle flow, in the caster's fastest time constant: for the fast path's
#: prediction (numbers: cheap) and for the NLP (symbolic: each step deepens every later
#: stage's expressions; a finer step there made IPOPT much slower for little less error:
#: docs/design/caster-steer-prediction.md).
PREDICTION_STEP = 1.0
NLP_STEP = 2.5


def substeps(robot: CasterGeometry, duration: float, step: float = PREDICTION_STEP) -> int:
    """RK4 steps over ``duration`` [s] such that the caster's fastest rate of alignment,
    ``(r max_wheel_speed + d max_steer_rate) / d`` [1/s], times a step stays <= ``step``."""
    rates = (robot.radii * robot.nominal_max_wheel_speed + robot.offsets * robot.max_steer_rates
             ) / robot.offsets
    return max(1, math.ceil(duration * float(rates.max()) / step))


#: Most RK4 steps of the steer-angle prediction over one plan (bounds of this library): its
#: CasADi function is built on the first tick in time about linear in the steps; the NLP's
#: symbolic limits nest every step in every later stage, in time about quadratic
#: (docs/design/caster-steer-prediction.md). Fast-aligning casters (a small offset) on a
#: long horizon need many steps.
MAX_PREDICTION_STEPS = 1000
MAX_NLP_PREDICTION_STEPS = 120


def check_prediction(robot: CasterGeometry, durations: FloatArray, step: float = PREDICTION_STEP,
                     bound: int = MAX_PREDICTION_STEPS) -> None:
    """RobotError unless predicting the steer angles over stages of ``durations`` [s] in RK4
    steps of ``step`` time constants takes at most ``bound`` steps."""
    steps = sum(substeps(robot, float(duration), step) for duration in durations)
    if steps > bound:
        raise RobotError(
            f"robot {robot.name!r}: predicting its steer angles over {len(durations)} stages "
            f"({float(np.sum(durations)):g} s) takes {steps} RK4 steps (its casters align in "
            f"{1.0 / substeps(robot, 1.0):.3g} s at the fastest: offset, wheel_radius, "
            f"max_wheel_speed, max_steer_rate); at most {bound} (a bound of this library"
            f"{' for solver=ipopt' if step == NLP_STEP else ''}): shorten the horizon or "
            "stage_dt")


def _flow(robot: CasterGeometry, angles: ca.SX, twist: ca.SX, duration: float,
          step: float = PREDICTION_STEP) -> ca.SX:
    """The angles (n) after ``twist`` is held for ``duration`` [s] (RK4, symbolic)."""
    count = substeps(robot, duration, step)
    h = duration / count
    betadot = _rate(robot)

    def rate(beta: ca.SX) -> ca.SX:
        return betadot(beta, twist)

    beta = angles
    for _ in range(count):
        k1 = rate(beta)
        k2 = rate(beta + 0.5 * h * k1)
        k3 = rate(beta + 0.5 * h * k2)
        k4 = rate(beta + h * k3)
        beta = beta + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return beta


def _rate(robot: CasterGeometry) -> ca.Function:
    """``betadot = S(beta) u`` as a CasADi function, built once per robot: called on
    symbols it writes the same expression as building the rows afresh, in a fraction of
    the Python time (docs/design/caster-steer-prediction.md)."""
    cached = robot._cache.get("betadot")
    if cached is None:
        beta, twist = ca.SX.sym("beta", robot.n_wheels), ca.SX.sym("u", 3)
        rates = ca.vertcat(*[_symbolic_rows(robot, beta[i], i)[1] @ twist
                             for i in range(robot.n_wheels)])
        cached = robot._cache["betadot"] = ca.Function("betadot", [beta, twist], [rates])
    return cached


class _Predictor:
    """The steer-angle prediction over one grid of ``durations``: a CasADi function
    ``(beta_0 (n), twists (3 x k)) -> angles (n x k+1)`` evaluated through its buffers (a
    call by NumPy arguments costs more than the RK4 itself on a short grid), each thread
    with its own."""

    def __init__(self, robot: CasterGeometry, durations: tuple[float, ...]) -> None:
        start = ca.SX.sym("beta0", robot.n_wheels)
        twists = ca.SX.sym("u", 3, len(durations))
        columns = [start]
        for k, duration in enumerate(durations):
            columns.append(_flow(robot, columns[-1], twists[:, k], duration))
        self.function = ca.Function("caster_angles", [start, twists], [ca.horzcat(*columns)])
        self._shape = (robot.n_wheels, len(durations))
        self._local = threading.local()

    def __call__(self, angles: FloatArray, twists: FloatArray) -> FloatArray:
        """Angles (k+1, n) [rad] from ``angles`` (n,) under ``twists`` (k, 3)."""
        local = self._local
        evaluate: BufferedFunction | None = getattr(local, "evaluate", None)
        if evaluate is None:
            n, k = self._shape
            # CasADi reads a C-ordered (k, 3) array as its 3 x k argument, and writes its
            # n x (k+1) result as a C-ordered (k+1, n) one.
            local.arrays = (np.zeros(n), np.zeros((k, 3)), np.zeros((k + 1, n)))
            evaluate = local.evaluate = BufferedFunction(self.function, local.arrays[:2],
                                                         local.arrays[2:])
        start, held, out = local.arrays
        start[:] = angles
        held[:] = twists
        evaluate()
        return out.copy()

    def __getstate__(self) -> dict[str, object]:  # a robot that is copied or pickled
        return {"function": self.function, "_shape": self._shape}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._local = threading.local()


def _predictor(robot: CasterGeometry, durations: tuple[float, ...]) -> _Predictor:
    """The prediction over ``durations``, built once per grid (and robot)."""
    key = ("predictor", durations)
    cached = robot._cache.get(key)
    if cached is None:
        cached = robot._cache[key] = _Predictor(robot, durations)
    return cached


def predict(robot: CasterGeometry, angles: FloatArray, twists: FloatArray,
            durations: FloatArray) -> FloatArray:
    """Angles (k+1, n) [rad] from ``angles`` (n,) under ``twists`` (k, 3) held for
    ``durations`` (k,) [s]."""
    twists = np.asarray(twists, dtype=float).reshape(-1, 3)
    steps = tuple(float(h) for h in np.asarray(durations, dtype=float).reshape(-1))
    if len(steps) != twists.shape[0]:
        raise RobotError(f"predict_steer_angles needs one duration per twist, got "
                         f"{len(steps)} durations for {twists.shape[0]} twists")
    if not steps:
        return np.asarray(angles, dtype=float)[None, :].copy()
    return _predictor(robot, steps)(np.asarray(angles, dtype=float), twists)


def stage_limits(robot: CasterGeometry, change_times: FloatArray) -> StageLimits:
    """Rows a stage: ``n`` drive rows, ``n`` steer rows, and ``n`` drive-change rows with an
    acceleration limit; filled at zero angles until the first tick refills them."""
    n = robot.n_wheels
    horizon = len(change_times)
    accel = robot.max_wheel_accel
    m = 3 * n if accel is not None else 2 * n
    now = np.zeros((horizon, m, 3))
    before = np.zeros((horizon, m, 3))
    bound = np.zeros((horizon, m))
    bound[:, :n] = robot.max_wheel_speed
    bound[:, n:2 * n] = robot.max_steer_rates
    if accel is not None:
        bound[:, 2 * n:] = accel[None, :] * np.asarray(change_times, dtype=float)[:, None]
    limits = StageLimits(now=now, before=before, lower=-bound, upper=bound, constant=False,
                         change_times=np.array(change_times, dtype=float))
    limits.memory["durations"] = np.array(change_times[1:], dtype=float)
    check_prediction(robot, limits.memory["durations"])
    if horizon > 1:  # built now, not on the first tick
        _predictor(robot, tuple(float(h) for h in limits.memory["durations"]))
    _fill(robot, limits, np.zeros((horizon, n)))
    return limits


def _fill(robot: CasterGeometry, limits: StageLimits, angles: FloatArray) -> None:
    n = robot.n_wheels
    drive, steer = joint_rows(robot, angles)  # (N, n, 3)
    limits.now[:, :n] = drive
    limits.now[:, n:2 * n] = steer
    if limits.rows > 2 * n:
        limits.now[:, 2 * n:] = drive
        limits.before[:, 2 * n:] = -drive
    limits.changed = True


def update_stage_limits(robot: CasterGeometry, limits: StageLimits, guess: FloatArray,
                        steer_angles: FloatArray | None) -> None:
    """Refill every stage's rows at the angles the guess twists turn the casters through
    from the measured ones."""
    if steer_angles is None:
        raise RobotError("a caster robot's limits need the measured steer angles")
    angles = predict(robot, steer_angles, guess[:-1], limits.memory["durations"])
    limits.memory["angles"] = angles
    _fill(robot, limits, angles)


def nlp_stage_limits(robot: CasterGeometry, twists: ca.SX, last: ca.SX,
                     steer_angles: ca.SX | None, change_times: FloatArray
                     ) -> tuple[list[ca.SX], list[FloatArray], list[FloatArray]]:
    """Exact joint limits at the angles integrated symbolically from the measured ones."""
    if steer_angles is None:
        raise RobotError("a caster robot's NLP needs the steer angles as a parameter")
    durations = np.asarray(change_times[1:], dtype=float)
    check_prediction(robot, durations)
    check_prediction(robot, durations, NLP_STEP, MAX_NLP_PREDICTION_STEPS)
    n = robot.n_wheels
    speed, steer_max, accel = robot.max_wheel_speed, robot.max_steer_rates, robot.max_wheel_accel
    values: list[ca.SX] = []
    lower: list[FloatArray] = []
    upper: list[FloatArray] = []
    beta = steer_angles
    horizon = twists.shape[1]
    for k in range(horizon):
        u = twists[:, k]
        rows = [_symbolic_rows(robot, beta[i], i) for i in range(n)]
        drive = ca.vertcat(*[row[0] @ u for row in rows])
        values += [drive, ca.vertcat(*[row[1] @ u for row in rows])]
        lower += [-speed, -steer_max]
        upper += [speed.copy(), steer_max.copy()]
        if accel is not None:
            change = u - (last if k == 0 else twists[:, k - 1])
            values.append(ca.vertcat(*[row[0] @ change for row in rows]))
            bound = accel * float(change_times[k])
            lower.append(-bound)
            upper.append(bound)
        if k + 1 < horizon:
            beta = _flow(robot, beta, u, float(change_times[k + 1]), NLP_STEP)
    return values, lower, upper


def clamp_at(robot: CasterGeometry, target: FloatArray, last: FloatArray, dt: float,
             angles: FloatArray) -> FloatArray:
    """``target`` within every joint limit at the measured ``angles`` (module docstring)."""
    drive, steer = joint_rows(robot, angles)
    speed = robot.max_wheel_speed
    failed = speed <= 0.0
    if failed.any():  # keep a failed wheel's drive at rest: project its motion out
        rows = drive[failed]
        target = target - np.linalg.pinv(rows) @ (rows @ target)
    rows = np.vstack([drive, steer])
    bound = np.concatenate([speed, robot.max_steer_rates])
    value = rows @ target
    tolerance = bound * _SLACK + 1e-12
    accel = robot.max_wheel_accel
    step = target - last
    accel_value = drive @ step if accel is not None else None
    accel_bound = accel * dt if accel is not None else None
    if np.all(np.abs(value) <= bound + tolerance) and (
            accel_value is None or accel_bound is None
            or np.all(np.abs(accel_value) <= accel_bound * (1.0 + _SLACK) + 1e-12)):
        return target
    start = rows @ last
    if np.all(np.abs(start) <= bound + tolerance):
        fraction = _largest_fraction(start, rows @ step, bound)
        if accel_value is not None and accel_bound is not None:
            fraction = min(fraction, _largest_fraction(np.zeros_like(accel_value),
                                                       accel_value, accel_bound))
        return last + fraction * (1.0 - _SLACK) * step
    # The last command breaks a limit at the new angles: the limits win over acceleration.
    magnitude = np.abs(value)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.where(magnitude > 1e-12, bound / magnitude, np.inf)
    return target * min(1.0, float(ratios.min())) * (1.0 - _SLACK)


def _largest_fraction(start: FloatArray, rate: FloatArray, bound: FloatArray) -> float:
    """The largest ``f`` in [0, 1] with ``|start + f rate| <= bound`` (``|start| <= bound``)."""
    fraction = 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(rate > 1e-15, (bound - start) / rate, np.inf)
        down = np.where(rate < -1e-15, (-bound - start) / rate, np.inf)
    fraction = min(fraction, float(up.min()), float(down.min()))
    return max(0.0, fraction)
