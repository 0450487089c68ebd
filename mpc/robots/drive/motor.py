"""DC motor models: WPILib's ``DCMotor`` physics (and SysId's ``kS, kV, kA``, re-exported).

:class:`DCMotor` is the steady-state brushed/brushless DC motor of WPILib's
``frc::DCMotor``, with the same parameters, derived constants, formulas and
presets, so FRC teams can carry their numbers over unchanged. For a gearbox
of ``count`` motors on one shaft::

    R  = V_nom / (count * I_stall)                 [ohm]       (WPILib ``R``)
    kv = w_free / (V_nom - R * count * I_free)     [rad/s/V]   (WPILib ``Kv``)
    kt = (count * T_stall) / (count * I_stall)     [N m/A]     (WPILib ``Kt``)

    V = w / kv + R * T / kt        (voltage for torque T at speed w)
    I = (V - w / kv) / R = T / kt  (current)
    w = kv * (V - R * T / kt)      (speed for torque T at voltage V)

``T`` is the gearbox's output torque (all motors together) and ``w`` the
shaft speed; :meth:`DCMotor.with_reduction` moves both to the far side of a
gear reduction (torque times ``gearing``, speed divided by it).

:class:`SysIdMotor` (SysId's ``kS, kV, kA`` per wheel) is in :mod:`mpc.robots.drive.sysid_motor`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from mpc.errors import RobotError
from mpc.robots.drive.sysid_motor import SysIdMotor, Value
from mpc.validation import integer_at_least, non_negative, positive, shown

__all__ = ["MOTOR_PRESETS", "DCMotor", "SysIdMotor", "Value"]

_RPM = math.pi / 30.0  # [rad/s per rpm], the conversion WPILib's units library applies

#: WPILib's preset motors: (nominal voltage [V], stall torque [N m], stall current [A],
#: free current [A], free speed [rpm]) per motor, from frc/system/plant/DCMotor.h.
_PRESETS: dict[str, tuple[float, float, float, float, float]] = {
    "cim": (12.0, 2.42, 133.0, 2.7, 5310.0),
    "mini_cim": (12.0, 1.41, 89.0, 3.0, 5840.0),
    "bag": (12.0, 0.43, 53.0, 1.8, 13180.0),
    "vex_775pro": (12.0, 0.71, 134.0, 0.7, 18730.0),
    "rs775_125": (12.0, 0.28, 18.0, 1.6, 5800.0),
    "banebots_rs775": (12.0, 0.72, 97.0, 2.7, 13050.0),
    "andymark_9015": (12.0, 0.36, 71.0, 3.7, 14270.0),
    "banebots_rs550": (12.0, 0.38, 84.0, 0.4, 19000.0),
    "neo": (12.0, 2.6, 105.0, 1.8, 5676.0),
    "neo_550": (12.0, 0.97, 100.0, 1.4, 11000.0),
    "neo_vortex": (12.0, 3.60, 211.0, 3.615, 6784.0),
    "falcon_500": (12.0, 4.69, 257.0, 1.5, 6380.0),
    "falcon_500_foc": (12.0, 5.84, 304.0, 1.5, 6080.0),
    "kraken_x60": (12.0, 7.09, 366.0, 2.0, 6000.0),
    "kraken_x60_foc": (12.0, 9.37, 483.0, 2.0, 5800.0),
    "kraken_x44": (12.0, 4.11, 279.0, 2.0, 7758.0),
    "kraken_x44_foc": (12.0, 5.01, 329.0, 2.0, 7368.0),
    "minion": (12.0, 3.17, 211.0, 2.0, 7704.0),
    "romi_builtin": (4.5, 0.1765, 1.25, 0.13, 150.0),
}

#: Names accepted by :meth:`DCMotor.preset` (each also a classmethod of the same name).
MOTOR_PRESETS: tuple[str, ...] = tuple(_PRESETS)


@dataclass(frozen=True)
class DCMotor:
    """A gearbox of ``count`` identical DC motors (WPILib's ``DCMotor``; module docstring).

    Attributes:
        nominal_voltage: voltage the constants were measured at [V].
        stall_torque: torque of one motor at stall [N m].
        stall_current: current of one motor at stall [A].
        free_current: current of one motor with no load [A], below ``stall_current``
            (0 allowed: an ideal motor).
        free_speed: speed with no load [rad/s].
        count: motors on the shaft, an integer >= 1.
    """

    nominal_voltage: float
    stall_torque: float
    stall_current: float
    free_current: float
    free_speed: float
    count: int = 1

    def __post_init__(self) -> None:
        for name in ("nominal_voltage", "stall_torque", "stall_current", "free_speed"):
            unit = {"nominal_voltage": "V", "stall_torque": "N m", "free_speed": "rad/s"}
            label = f"{name} [{unit.get(name, 'A')}]"
            object.__setattr__(self, name, positive(label, getattr(self, name), RobotError))
        free = non_negative("free_current [A]", self.free_current, RobotError)
        object.__setattr__(self, "free_current", free)
        object.__setattr__(self, "count", integer_at_least("count", self.count, 1, RobotError))
        if free >= self.stall_current:
            raise RobotError(f"free_current must be below stall_current, got free_current "
                             f"{shown(free)} A and stall_current {shown(self.stall_current)} A")

    # ------------------------------------------------------------ presets
    @classmethod
    def preset(cls, name: str, count: int = 1) -> DCMotor:
        """A gearbox of ``count`` of WPILib's preset motor ``name`` (see :data:`MOTOR_PRESETS`)."""
        if name not in _PRESETS:
            raise RobotError(f"unknown motor preset {name!r}; expected one of {list(_PRESETS)}")
        voltage, torque, stall, free, rpm = _PRESETS[name]
        return cls(voltage, torque, stall, free, rpm * _RPM, count)

    @classmethod
    def cim(cls, count: int = 1) -> DCMotor:
        """CIM (WPILib ``CIM``)."""
        return cls.preset("cim", count)

    @classmethod
    def mini_cim(cls, count: int = 1) -> DCMotor:
        """MiniCIM (WPILib ``MiniCIM``)."""
        return cls.preset("mini_cim", count)

    @classmethod
    def bag(cls, count: int = 1) -> DCMotor:
        """BAG (WPILib ``Bag``)."""
        return cls.preset("bag", count)

    @classmethod
    def vex_775pro(cls, count: int = 1) -> DCMotor:
        """VEX 775pro (WPILib ``Vex775Pro``)."""
        return cls.preset("vex_775pro", count)

    @classmethod
    def rs775_125(cls, count: int = 1) -> DCMotor:
        """AndyMark RS775-125 (WPILib ``RS775_125``)."""
        return cls.preset("rs775_125", count)

    @classmethod
    def banebots_rs775(cls, count: int = 1) -> DCMotor:
        """BaneBots RS-775 (WPILib ``BanebotsRS775``)."""
        return cls.preset("banebots_rs775", count)

    @classmethod
    def banebots_rs550(cls, count: int = 1) -> DCMotor:
        """BaneBots RS-550 (WPILib ``BanebotsRS550``)."""
        return cls.preset("banebots_rs550", count)

    @classmethod
    def andymark_9015(cls, count: int = 1) -> DCMotor:
        """AndyMark 9015 (WPILib ``Andymark9015``)."""
        return cls.preset("andymark_9015", count)

    @classmethod
    def neo(cls, count: int = 1) -> DCMotor:
        """REV NEO (WPILib ``NEO``)."""
        return cls.preset("neo", count)

    @classmethod
    def neo_550(cls, count: int = 1) -> DCMotor:
        """REV NEO 550 (WPILib ``NEO550``)."""
        return cls.preset("neo_550", count)

    @classmethod
    def neo_vortex(cls, count: int = 1) -> DCMotor:
        """REV NEO Vortex (WPILib ``NeoVortex``)."""
        return cls.preset("neo_vortex", count)

    @classmethod
    def falcon_500(cls, count: int = 1) -> DCMotor:
        """Falcon 500 (WPILib ``Falcon500``)."""
        return cls.preset("falcon_500", count)

    @classmethod
    def falcon_500_foc(cls, count: int = 1) -> DCMotor:
        """Falcon 500 with field-oriented control (WPILib ``Falcon500FOC``)."""
        return cls.preset("falcon_500_foc", count)

    @classmethod
    def kraken_x60(cls, count: int = 1) -> DCMotor:
        """Kraken X60 (WPILib ``KrakenX60``)."""
        return cls.preset("kraken_x60", count)

    @classmethod
    def kraken_x60_foc(cls, count: int = 1) -> DCMotor:
        """Kraken X60 with field-oriented control (WPILib ``KrakenX60FOC``)."""
        return cls.preset("kraken_x60_foc", count)

    @classmethod
    def kraken_x44(cls, count: int = 1) -> DCMotor:
        """Kraken X44 (WPILib ``KrakenX44``)."""
        return cls.preset("kraken_x44", count)

    @classmethod
    def kraken_x44_foc(cls, count: int = 1) -> DCMotor:
        """Kraken X44 with field-oriented control (WPILib ``KrakenX44FOC``)."""
        return cls.preset("kraken_x44_foc", count)

    @classmethod
    def minion(cls, count: int = 1) -> DCMotor:
        """CTRE Minion (WPILib ``Minion``)."""
        return cls.preset("minion", count)

    @classmethod
    def romi_builtin(cls, count: int = 1) -> DCMotor:
        """Romi / TI-RSLK MAX gear motor (WPILib ``RomiBuiltIn``)."""
        return cls.preset("romi_builtin", count)

    # ------------------------------------------------------------ derived constants
    @property
    def total_stall_torque(self) -> float:
        """Stall torque of the gearbox, ``count * stall_torque`` [N m] (WPILib ``stallTorque``)."""
        return self.stall_torque * self.count

    @property
    def total_stall_current(self) -> float:
        """Stall current of the gearbox [A] (WPILib ``stallCurrent``)."""
        return self.stall_current * self.count

    @property
    def total_free_current(self) -> float:
        """Free current of the gearbox [A] (WPILib ``freeCurrent``)."""
        return self.free_current * self.count

    @property
    def R(self) -> float:  # WPILib's name
        """Winding resistance of the gearbox, ``V_nom / (count I_stall)`` [ohm] (WPILib ``R``)."""
        return self.nominal_voltage / self.total_stall_current

    @property
    def kv(self) -> float:
        """Velocity constant ``w_free / (V_nom - R count I_free)`` [rad/s per V] (WPILib ``Kv``)."""
        return self.free_speed / (self.nominal_voltage - self.R * self.total_free_current)

    @property
    def kt(self) -> float:
        """Torque constant ``T_stall / I_stall`` [N m per A] (WPILib ``Kt``)."""
        return self.total_stall_torque / self.total_stall_current

    # ------------------------------------------------------------ physics
    def voltage(self, torque: Value, speed: Value) -> Value:
        """Voltage [V] for output torque [N m] at shaft speed [rad/s] (WPILib ``Voltage``)."""
        return 1.0 / self.kv * speed + 1.0 / self.kt * self.R * torque

    def current(self, speed: Value, voltage: Value) -> Value:
        """Current [A] at shaft speed [rad/s] and input voltage [V] (WPILib ``Current``)."""
        return -1.0 / self.kv / self.R * speed + 1.0 / self.R * voltage

    def current_for_torque(self, torque: Value) -> Value:
        """Current [A] for output torque [N m] (WPILib's ``Current(torque)`` overload)."""
        return torque / self.kt

    def torque(self, current: Value) -> Value:
        """Output torque [N m] for current [A] (WPILib ``Torque``)."""
        return current * self.kt

    def speed(self, torque: Value, voltage: Value) -> Value:
        """Shaft speed [rad/s] at output torque [N m] and voltage [V] (WPILib ``Speed``)."""
        return voltage * self.kv - 1.0 / self.kt * torque * self.R * self.kv

    def with_reduction(self, gearing: float) -> DCMotor:
        """The same motors behind a reduction of ``gearing`` (motor turns per output turn):
        torque times ``gearing``, speed divided by it (WPILib ``WithReduction``). ``count``
        is kept, so ``R``, ``kv * gearing`` and ``kt / gearing`` are unchanged."""
        ratio = positive("gearing", gearing, RobotError)
        return replace(self, stall_torque=self.stall_torque * ratio,
                       free_speed=self.free_speed / ratio)
