"""Array type aliases and small array helpers shared by every layer of :mod:`mpc`."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]


def readonly(array: ArrayLike) -> FloatArray:
    """A float copy of ``array`` that cannot be written to."""
    out = np.array(array, dtype=float)
    out.setflags(write=False)
    return out


def listed(**values: ArrayLike | None) -> dict[str, object]:
    """Numbers and arrays as plain Python lists and floats (None kept), by keyword: what a
    description in a TOML or JSON file holds."""
    return {key: None if value is None else np.asarray(value).tolist()
            for key, value in values.items()}
