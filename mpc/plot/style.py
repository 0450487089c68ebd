"""What every report figure shares: an Agg canvas without pyplot, PNG output, the marks.

Figures are :class:`matplotlib.figure.Figure` objects on their own Agg canvas: no display,
no global pyplot state, freed when dropped. Lengths are shown in mm, angles in deg, times
in s (tick times in ms).
"""

from __future__ import annotations

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
