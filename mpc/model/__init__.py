"""The model: CasADi dynamics and cost built once per robot, and the vector layouts.

Modules: :mod:`.se2` (rigid motion under a constant twist), :mod:`.layout`
(named slices of ``z`` and ``p``, the per-tick :class:`TickInput`),
:mod:`.weights`, :mod:`.tracking` (:class:`TrackingModel`), :mod:`.buffered`
(zero-copy CasADi calls).
"""

from mpc.buffered import BufferedFunction
from mpc.errors import ControllerError as _Error
from mpc.model.layout import Layout, TickInput, TrackingLayouts, tracking_layouts
from mpc.model.se2 import SMALL_ROTATION, integrate, twist_integral, twist_logarithm
from mpc.model.tracking import DIRECTION_SPEED, TrackingModel
from mpc.model.weights import Weights, load_weights, make_weights, tuned_layouts, tuned_weights
from mpc.validation import checked_public as _checked_public

__all__ = [
    "DIRECTION_SPEED",
    "SMALL_ROTATION",
    "BufferedFunction",
    "Layout",
    "TickInput",
    "TrackingLayouts",
    "TrackingModel",
    "Weights",
    "integrate",
    "load_weights",
    "make_weights",
    "tracking_layouts",
    "tuned_layouts",
    "tuned_weights",
    "twist_integral",
    "twist_logarithm",
]

# Arguments that do not fit a public callable's signature raise ControllerError, not TypeError.
_checked_public(globals(), _Error)
