"""The figures' common ground: a ``Figure`` on its own Agg canvas (no pyplot), and its atomic PNG write."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

from agvctl.fileio import atomic_open

__all__ = ["new_figure", "png_bytes", "save_png", "subplots"]


def new_figure(**kwargs: Any) -> Any:
    """A new ``Figure`` on an Agg canvas (``kwargs`` as for ``Figure``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def subplots(*grid: int, figsize: tuple[float, float], **kwargs: Any) -> tuple[Any, Any]:
    """``(figure, axes)`` like ``pyplot.subplots``, without pyplot."""
    fig = new_figure(figsize=figsize)
    return fig, fig.subplots(*grid, **kwargs)


def save_png(fig: Any, path: Path) -> None:
    """Write ``fig`` to ``path`` as a PNG, atomically."""
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)


def png_bytes(fig: Any, dpi: int) -> bytes:
    """``fig`` as PNG bytes at ``dpi`` dots per inch."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()
