"""Checks for arguments at the library's front door (constructors, ``step()``).

Each check raises the error type its caller passes, with a message that names
the argument and says what was expected and what arrived.
"""

from __future__ import annotations

import enum
import functools
import inspect
import math
import numbers
import stat
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from mpc.arrays import FloatArray
from mpc.errors import MpcError

T = TypeVar("T")


def is_integer(value: object) -> bool:
    """An integer (Python or NumPy), but not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def as_float(value: object) -> float:
    """``float(value)``, with a number too large for a float (a huge int or Fraction) as
    ``inf`` (with its sign) instead of an OverflowError; NaN if it cannot convert at all."""
    try:
        return float(value)  # type: ignore[arg-type]
    except OverflowError:
        try:
            return math.copysign(math.inf, 1.0 if value > 0 else -1.0)  # type: ignore[operator]
        except (TypeError, ValueError):
            return math.nan
    except (TypeError, ValueError):
        return math.nan


def is_finite_number(value: object) -> bool:
    """A finite real number (Python or NumPy, a 0-d NumPy array of one too), but not a bool
    (a number too large for a float is not finite)."""
    if isinstance(value, numbers.Real):
        return not isinstance(value, bool) and math.isfinite(as_float(value))
    return (isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"
            and math.isfinite(as_float(value)))


_MAX_SHOWN = 80  # characters of a value quoted in an error message


def shown(value: object) -> str:
    """A one-line repr of ``value`` for an error message, at most about 80 characters: a
    huge integer as "an integer of N digits", a NumPy array on one line."""
    try:
        if isinstance(value, (np.generic, np.ndarray)) and np.ndim(value) == 0:
            value = value.item()  # type: ignore[union-attr]
        if (isinstance(value, numbers.Integral) and not isinstance(value, bool)
                and abs(int(value)) >= 10**60):
            digits = int(int(value).bit_length() * math.log10(2)) + 1
            return f"an integer of about {digits} digits"
        if isinstance(value, np.ndarray):
            text = np.array2string(value, separator=", ", threshold=20, max_line_width=10**6)
            text = f"array({' '.join(text.split())})"
        else:
            text = " ".join(repr(value).split())
    except RecursionError:
        text = f"a {type(value).__name__} nested too deeply to show"
    except (ValueError, OverflowError):
        text = f"a {type(value).__name__} holding an integer too large to show"
    return text if len(text) <= _MAX_SHOWN else text[:_MAX_SHOWN - 3] + "..."


def finite(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number."""
    if not is_finite_number(value):
        raise error(f"{name} must be a finite number, got {shown(value)}")
    return as_float(value)


def positive(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number > 0."""
    if not is_finite_number(value) or as_float(value) <= 0.0:
        raise error(f"{name} must be a finite number > 0, got {shown(value)}")
    return as_float(value)


def non_negative(name: str, value: object, error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a finite real number >= 0."""
    if not is_finite_number(value) or as_float(value) < 0.0:
        raise error(f"{name} must be a finite number >= 0, got {shown(value)}")
    return as_float(value)


def integer_at_least(name: str, value: object, low: int,
                     error: type[MpcError] = MpcError) -> int:
    """``value`` as an int, or ``error`` unless it is an integer >= ``low`` (bools refused)."""
    if not is_integer(value) or int(value) < low:  # type: ignore[call-overload]
        raise error(f"{name} must be an integer >= {low}, got {shown(value)}")
    return int(value)  # type: ignore[call-overload]


def flag(name: str, value: object, error: type[MpcError] = MpcError) -> bool:
    """``value`` if it is a bool (NumPy bools too), else ``error``: no truthy strings."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{name} must be True or False, got {shown(value)}")
    return bool(value)


def has_bool(value: object) -> bool:
    """Whether ``value`` is a bool or a (nested) list, tuple or array holding one."""
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        return any(has_bool(item) for item in value)
    return isinstance(value, np.ndarray) and value.dtype == np.bool_


def real_array(name: str, value: object, expected: str,
               error: type[MpcError] = MpcError) -> FloatArray:
    """``value`` as a float array (any shape), or ``error`` saying ``name`` must be
    ``expected`` unless every entry is a real number: booleans, strings (numeric ones too),
    complex numbers, None and ragged lists are refused, not converted."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, RecursionError):  # ragged, or nested too deeply
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf" or has_bool(value):
        raise error(f"{name} must be {expected}, got {shown(value)}")
    return raw.astype(float)


def finite_vector(name: str, value: ArrayLike, length: int, what: str,
                  error: type[MpcError] = MpcError) -> FloatArray:
    """A float array of shape ``(length,)`` with finite entries (``what`` names them)."""
    array = real_array(name, value, f"{length} numbers {what}", error)
    if array.shape != (length,):
        raise error(f"{name} must have shape ({length},) as {what}, got shape {array.shape}")
    if not math.isfinite(float(np.abs(array).max(initial=0.0))):
        raise error(f"{name} must be finite, got {array.tolist()}")
    return array


# Bounds on every size a user controls: checked before anything is allocated, so that a
# typo (a horizon of a million) fails at once with a clear message instead of exhausting
# memory or hanging. Each is far beyond any real use.

#: Wheels (or modules) on one robot.
MAX_WHEELS = 64
#: Stages in a plan (``horizon``).
MAX_HORIZON = 1000
#: Longest tick or plan stage (``dt``, ``stage_dt``) [s]: a minute.
MAX_STEP = 60.0
#: Stages in a plan solved by ``solver="daqp"``: its dense QP's first solve grows as the
#: horizon cubed (about 3.5 s for the swerve preset at 300 stages, 87 s for Mecanum at 1000).
MAX_DENSE_HORIZON = 300
#: Entries of ``solver="daqp"``'s dense limit matrix (limit rows x 3 horizon): 256 MiB.
MAX_DENSE_ENTRIES = 2**25
#: Limit rows in one plan of a QP path (horizon x rows a stage: wheels, polygon sides).
MAX_PLAN_ROWS = 2**18
#: Ticks of known command delay (``delay_ticks``).
MAX_DELAY_TICKS = 1000
#: Sides of a swerve module's QP polygon (``polygon_sides``).
MAX_POLYGON_SIDES = 256
#: Solver iterations per tick (``max_iter``).
MAX_ITERATIONS = 1_000_000
#: Ticks in one simulation (``duration / dt``).
MAX_SIMULATION_TICKS = 5_000_000
#: Bytes in a robot, reference or results file read as text.
MAX_FILE_BYTES = 64 * 1024 * 1024
#: Largest coordinate of a pose [m] (and heading [rad]): well past UTM's, far from overflow.
MAX_COORDINATE = 1e9
#: Largest size in a robot's geometry [m] (a wheel's distance from the body origin, a base
#: radius, wheelbase, track, wheel radius or caster offset): far past any vehicle, far from
#: overflow in the wheel Jacobian.
MAX_LENGTH = 1e3
#: Smallest positive size in a robot's geometry [m] (wheel radius, base radius, wheelbase,
#: track, caster offset): a micrometre.
MIN_LENGTH = 1e-6
#: Smallest limit of a wheel or steering rate [rad/s, or rad/s^2 for accelerations] (before
#: derating): the clamp's rounding slack is relative to the limits, and limits far below this
#: would take the QP rows and the clamp's ratios towards underflow; 1e-6 rad/s turns a
#: 5 cm wheel 5 nm a second.
MIN_RATE = 1e-6
#: Largest time a controller is stepped at [s] (ROS epoch stamps are about 1.8e9 s; at
#: 1e10 s a double still resolves 2 us).
MAX_TIME = 1e10


def integer_in(name: str, value: object, low: int, high: int,
               error: type[MpcError] = MpcError) -> int:
    """``value`` as an int, or ``error`` unless it is an integer in ``[low, high]`` (the
    message names the bound)."""
    if not is_integer(value):
        raise error(f"{name} must be an integer in {low}..{high}, got {shown(value)}")
    number = int(value)  # type: ignore[call-overload]
    if number < low:
        raise error(f"{name} must be an integer >= {low}, got {shown(value)}")
    if number > high:
        raise error(f"{name} must be at most {high} (a bound of this library), got {shown(value)}")
    return number


def metres(name: str, value: object, error: type[MpcError] = MpcError, *,
           zero: bool = False) -> float:
    """``value`` [m] as a float, or ``error`` unless it is a real number in
    ``[MIN_LENGTH, MAX_LENGTH]`` (or exactly 0 if ``zero``): the message states the bounds."""
    if is_finite_number(value) and (zero and as_float(value) == 0.0
                                    or MIN_LENGTH <= as_float(value) <= MAX_LENGTH):
        return as_float(value)
    low = "0" if zero else f"{MIN_LENGTH:g}"
    raise error(f"{name} must be a number of metres in [{low}, {MAX_LENGTH:g}] (bounds of "
                f"this library), got {shown(value)}")


def bounded(name: str, value: object, bound: float, unit: str,
            error: type[MpcError] = MpcError) -> float:
    """``value`` as a float, or ``error`` unless it is a real number within ``+-bound``."""
    if not is_finite_number(value) or not abs(as_float(value)) <= bound:
        raise error(f"{name} must be a finite number within +-{bound:g} {unit} (a bound of "
                    f"this library), got {shown(value)}")
    return as_float(value)


def within(name: str, array: FloatArray, bound: float, unit: str,
           error: type[MpcError] = MpcError) -> FloatArray:
    """``array`` unless an entry is not finite or beyond ``+-bound`` (then ``error`` naming
    the first such entry and the bound); the check itself cannot overflow."""
    bad = ~(np.abs(array) <= bound)  # NaN compares False: caught too
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f"{name}[{', '.join(map(str, index))}]" if index else name
        raise error(f"{name} must be finite and within +-{bound:g} {unit} (a bound of this "
                    f"library), got {where}={float(array[index])!r}")
    return array


def body_points(name: str, value: object, what: str,
                error: type[MpcError] = MpcError) -> FloatArray:
    """Body-frame points [m] as an (n, 2) float array, n >= 2 (``what`` names them:
    "modules", "balls"), each coordinate within +-:data:`MAX_LENGTH` and every two at least
    :data:`MIN_LENGTH` apart (two wheels cannot stand in one place), or ``error``."""
    points = real_array(name, value, "an (n, 2) array of numbers [m]", error)
    if points.ndim != 2 or points.shape[1] != 2 or points.shape[0] < 2:
        raise error(f"{name} must have shape (n, 2) with n >= 2 {what}, "
                    f"got shape {points.shape}")
    points = within(name, points, MAX_LENGTH, "[m]", error)
    gaps = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    close = np.argwhere(np.triu(gaps < MIN_LENGTH, k=1))
    if close.size:
        i, j = (int(v) for v in close[0])
        raise error(f"{name}: {what} {i} and {j} must stand apart (at least {MIN_LENGTH:g} m), "
                    f"got {points[i].tolist()} and {points[j].tolist()} m")
    return points


def file_text(path: object, what: str, error: type[MpcError] = MpcError) -> str:
    """The UTF-8 text of the file at ``path`` (a byte-order mark allowed), or ``error`` naming
    the file: missing, a folder, larger than :data:`MAX_FILE_BYTES`, or not UTF-8."""
    from os import PathLike
    from pathlib import Path

    try:
        if not isinstance(path, (str, PathLike)):
            raise error(f"{what} file must be a path (str or os.PathLike), got {path!r}")
        file = Path(path)
        mode = file.stat().st_mode if file.exists() else 0
        if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):  # open() would block forever
            raise error(f"{what} file {str(file)!r} is not a regular file (a named pipe "
                        "or socket)")
        with file.open("rb") as stream:  # read at most the bound: devices report size 0
            data = stream.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            size = max(file.stat().st_size, len(data))
            raise error(f"{what} file {str(file)!r} is {size} bytes; at most "
                        f"{MAX_FILE_BYTES} are read")
        return data.decode("utf-8-sig")
    except MpcError:
        raise
    except UnicodeDecodeError as exc:
        raise error(f"{what} file {str(path)!r} is not UTF-8 text (byte {exc.start})") from None
    except FileNotFoundError:
        raise error(f"{what} file {str(path)!r} does not exist") from None
    except (OSError, TypeError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise error(f"cannot read {what} file {str(path)!r}: {reason}") from None


def parsed(parse: Callable[[str], T], text: str, where: str, language: str,
           error: type[MpcError] = MpcError) -> T:
    """``parse(text)`` (``json.loads``, ``tomllib.loads``), or ``error`` naming ``where`` (the
    file) for a syntax error, arrays nested too deeply or an integer too long to convert."""
    try:
        return parse(text)
    except RecursionError:
        raise error(f"{where}: not usable {language}: nested too deeply") from None
    except ValueError as exc:  # JSONDecodeError and TOMLDecodeError are ValueErrors too
        raise error(f"{where}: not valid {language}: {exc}") from None


F = TypeVar("F", bound=Callable[..., Any])


def checked_arguments(error: type[MpcError]) -> Callable[[F], F]:
    """Decorate a public callable so that arguments that do not fit its signature (an
    unknown keyword, a missing or an extra one) raise ``error`` naming the callable and its
    parameters, not Python's TypeError."""

    def decorate(function: F) -> F:
        signature = inspect.signature(function)
        names = [name for name in signature.parameters if name != "self"]
        shown = function.__qualname__.replace(".__init__", "")

        @functools.wraps(function)
        def checked(*args: Any, **kwargs: Any) -> Any:
            # Call first and look at the signature only on a TypeError: free on the hot
            # path (Controller.step), and a TypeError from inside the call goes on as is.
            try:
                return function(*args, **kwargs)
            except TypeError:
                try:
                    signature.bind(*args, **kwargs)
                except TypeError as problem:
                    unknown = sorted(set(kwargs) - set(names))
                    reason = (f"unknown keyword argument(s) {', '.join(map(repr, unknown))}"
                              if unknown else str(problem))
                    raise error(f"{shown}(): {reason}; its parameters are "
                                f"{', '.join(names)}") from None
                raise

        return checked  # type: ignore[return-value]

    return decorate


C = TypeVar("C", bound=type)


def checked_constructor(error: type[MpcError]) -> Callable[[C], C]:
    """Class decorator: :func:`checked_arguments` on the class's ``__init__`` (a dataclass's
    generated one too), so that ``Weights(colour=1)`` raises ``error`` naming the class."""

    def decorate(cls: C) -> C:
        setattr(cls, "__init__", checked_arguments(error)(vars(cls)["__init__"]))  # noqa: B010
        return cls

    return decorate


def checked_public(namespace: dict[str, Any], error: type[MpcError]) -> None:
    """:func:`checked_arguments` on every public callable of a package (the names in its
    ``namespace["__all__"]``): a function under the package's name, a class that defines its
    own ``__init__`` in place (:func:`checked_constructor`), so that ``time_optimal(path,
    robot, sampels=400)`` raises ``error`` naming the parameters. Protocols, abstract
    classes, enums, exceptions and named tuples are left as they are; so is anything already
    checked (a class two packages export keeps the first package's error)."""
    for name in namespace.get("__all__", ()):
        item = namespace.get(name)
        if inspect.isfunction(item):
            if not hasattr(item, "__wrapped__"):
                namespace[name] = checked_arguments(error)(item)
        elif inspect.isclass(item) and _own_constructor(item):
            checked_constructor(error)(item)


def _own_constructor(cls: type) -> bool:
    """Whether ``cls`` defines an unchecked ``__init__`` of its own and is a class users
    build (not a protocol, an abstract class, an enum or an exception)."""
    init = vars(cls).get("__init__")
    return (init is not None and not hasattr(init, "__wrapped__")
            and not issubclass(cls, (BaseException, enum.Enum))
            and not getattr(cls, "_is_protocol", False) and not inspect.isabstract(cls))
