"""The joint interface of robots whose steer angles are states the motion sets (casters):
drive and steer rates, their rows, the twist they give, the angles a plan turns the
wheels through, and the joint clamp. Other robots inherit these defaults, which raise
(or, for the clamp, defer to the generic one).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import RobotError


class SteerStateJoints:
    """Defaults of :class:`~mpc.robots.base.Robot` for the steer-state joint methods."""

    if TYPE_CHECKING:
        kind: ClassVar[str]
        name: str
        steered: ClassVar[bool]

        @property
        def n_wheels(self) -> int: ...

    def joint_parameter_size(self, horizon: int) -> int:
        """Numbers of joint state the solvers take each tick as a parameter, for a plan of
        ``horizon`` stages: the steer angles of steered wheels (n), none otherwise; a type
        with more joint states (sliders) says its own."""
        return self.n_wheels if self.steered else 0

    def joint_rates(self, twist: ArrayLike, steer_angles: ArrayLike) -> tuple[FloatArray,
                                                                             FloatArray]:
        """Robots whose steer angles are states (:attr:`steer_states`): drive rates and steer
        rates [rad/s], each (n,), for one twist at the given steer angles."""
        raise RobotError(f"robot {self.name!r} ({self.kind}) has no steer states")

    def joint_rows(self, steer_angles: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Robots whose steer angles are states: drive rows ``D`` and steer rows ``S``, each
        (..., n, 3), at steer angles (..., n) [rad]: ``phidot = D xi``, ``betadot = S xi``."""
        raise RobotError(f"robot {self.name!r} ({self.kind}) has no steer states")

    def joint_twist(self, drive_rates: FloatArray, steer_rates: FloatArray,
                    steer_angles: FloatArray) -> FloatArray:
        """Robots whose steer angles are states: the least-squares twist of drive and steer
        rates [rad/s] (n,) at the angles (n,) [rad], unchecked (the plant's hot path)."""
        raise RobotError(f"robot {self.name!r} ({self.kind}) has no steer states")

    def predict_steer_angles(self, steer_angles: FloatArray, twists: FloatArray,
                             durations: FloatArray) -> FloatArray:
        """Robots whose steer angles are states: the angles (k+1, n) [rad] that twists
        (k, 3), each held for its duration (k,) [s], turn the wheels through."""
        raise RobotError(f"robot {self.name!r} ({self.kind}) has no steer states")

    def clamp_joints(self, target: FloatArray, last: FloatArray, dt: float,
                     steer_angles: FloatArray) -> FloatArray | None:
        """Robots whose joint limits depend on measured steer angles (casters) bring the
        step from ``last`` towards ``target`` within them here; None (the default): the
        generic clamp of :func:`mpc.control.clamp.clamp_command` applies."""
        return None
