"""What every report figure shares: an Agg canvas without pyplot, PNG output, the marks.

Figures are :class:`matplotlib.figure.Figure` objects on their own Agg canvas: no display,
no global pyplot state, freed when dropped. Lengths are shown in mm, angles in deg, times
in s (tick times in ms).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

FIGURE_DPI = 100
#: Colour of the settling window (the ticks left out of the metrics) on time plots.
SKIP_COLOUR = "0.85"


def new_figure(width: float, height: float, constrained: bool) -> Figure:
    """A figure of ``width`` x ``height`` [inches] on its own Agg canvas (no pyplot).

    Constrained layout places legends and rotated labels well but takes about as long
    as drawing, so the per-run figures (one per run) use fixed margins instead.
    """
    figure = Figure(
        figsize=(width, height), dpi=FIGURE_DPI, layout="constrained" if constrained else None
    )
    FigureCanvasAgg(figure)
    return figure


def save(figure: Figure, path: Path) -> None:
    """Write a PNG. Nothing else refers to the figure (no pyplot), so it is freed on return."""
    figure.savefig(path, dpi=FIGURE_DPI)


def shade_skip(ax: Axes, start: float, skip: float) -> None:
    """Shade the settling window ``[start, start + skip]`` [s] of a time axis (left out of
    the metrics); nothing for ``skip`` <= 0."""
    if skip > 0 and np.isfinite(start):
        ax.axvspan(start, start + skip, color=SKIP_COLOUR, alpha=0.6, lw=0, zorder=0.5,
                   label=f"settling, not scored ({skip:g} s)")


def wrap_degrees(angle: np.ndarray) -> np.ndarray:
    """Wrap angles [rad] into (-180, 180] [deg]."""
    return np.degrees(np.pi - np.mod(np.pi - angle, 2.0 * np.pi))  # type: ignore[no-any-return]


#: Mantissas of labelled log ticks, from the sparsest: the first set giving 3-7 ticks is used
#: (else the first giving 2).
_LOG_STEPS: tuple[tuple[float, ...], ...] = (
    (1.0,), (1.0, 3.0), (1.0, 2.0, 5.0), (1.0, 1.5, 2.0, 3.0, 5.0, 7.0),
    tuple(float(m) for m in range(1, 10)))
_MAX_LOG_TICKS = 7


def log_ticks(low: float, high: float) -> list[float]:
    """Labelled ticks for a log axis spanning ``[low, high]`` (> 0): 3-7 values (2 where
    finer steps give too many) of 1, 1-3, 1-2-5 or finer steps per decade, or every n-th
    decade on wide spans."""
    if not (0 < low < high and math.isfinite(high)):
        return []
    first, last = math.floor(math.log10(low)), math.ceil(math.log10(high))
    fallback: list[float] = []
    for steps in _LOG_STEPS:
        ticks = [m * 10.0 ** e for e in range(first, last + 1) for m in steps
                 if low <= m * 10.0 ** e * (1 + 1e-9) and m * 10.0 ** e <= high * (1 + 1e-9)]
        if len(ticks) > _MAX_LOG_TICKS:
            if steps == _LOG_STEPS[0]:
                return ticks[::math.ceil(len(ticks) / _MAX_LOG_TICKS)]
            return fallback or _decades(first, last, low, high)
        if len(ticks) >= 3:
            return ticks
        fallback = fallback or (ticks if len(ticks) == 2 else [])
    return fallback or [low, high]


def _decades(first: int, last: int, low: float, high: float) -> list[float]:
    decades = [10.0 ** e for e in range(first, last + 1) if low <= 10.0 ** e <= high]
    stride = max(math.ceil(len(decades) / _MAX_LOG_TICKS), 1)
    return decades[::stride]


def tick_text(value: float) -> str:
    """A log tick's label: ``0.003``, ``20``, ``1e+05``; no overprinting exponents."""
    return f"{value:.6g}" if 1e-4 <= value < 1e5 else f"{value:.0e}"


def log_axis(ax: Axes, which: str, low: float, high: float) -> None:
    """Make ``ax``'s ``which`` axis (``"x"`` or ``"y"``) logarithmic over ``[low, high]``
    with plain labels that do not overprint on any span (:func:`log_ticks`); minor ticks
    unlabelled."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter

    axis = ax.xaxis if which == "x" else ax.yaxis
    (ax.set_xscale if which == "x" else ax.set_yscale)("log")
    (ax.set_xlim if which == "x" else ax.set_ylim)(low, high)
    ticks = log_ticks(low, high)
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(FuncFormatter(lambda value, _: tick_text(value)))
    axis.set_minor_locator(LogLocator(subs="all", numticks=12))
    axis.set_minor_formatter(NullFormatter())
