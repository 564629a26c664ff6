"""The figures' common ground: a ``Figure`` on its own Agg canvas (no pyplot), its atomic PNG write, and its PNG
bytes for a page."""

from __future__ import annotations

import io
import threading
from pathlib import Path
from typing import Any

from agvctl.fileio import atomic_open

__all__ = ["new_figure", "png_bytes", "save_png", "subplots"]

_UNHINTED = threading.Lock()
"""Held while a page's figure is drawn: its text is unhinted through matplotlib's global ``rcParams``, which two
threads drawing at once would otherwise set and restore over each other."""


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
    """``fig`` as PNG bytes at ``dpi`` dots per inch, for a page: its text unhinted (FreeType's autohinter takes a
    third of the time text takes to draw), the image opaque RGB at compression level 1 (half the time of
    matplotlib's RGBA at level 6, and smaller); the pixels are those ``savefig`` gives with unhinted text."""
    import matplotlib
    from PIL import Image

    fig.set_dpi(dpi)
    with _UNHINTED, matplotlib.rc_context({"text.hinting": "no_hinting"}):
        fig.canvas.draw()
    rgba = fig.canvas.buffer_rgba()
    image = Image.frombuffer("RGBA", (rgba.shape[1], rgba.shape[0]), rgba, "raw", "RGBA", 0, 1).convert("RGB")
    buf = io.BytesIO()
    image.save(buf, format="png", compress_level=1)
    return buf.getvalue()
