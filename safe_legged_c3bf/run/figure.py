"""A matplotlib figure on an Agg canvas, with no pyplot state: for files, never for screens."""

from __future__ import annotations

from typing import Any


def figure(size: tuple[float, float] = (8, 6), rows: int = 1, cols: int = 1) -> tuple[Any, Any]:
    """(figure, axes as a rows x cols array) of ``size`` inches at 100 dpi."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, cols, squeeze=False)
