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
    """A new matplotlib ``Figure`` on its own Agg canvas, drawn without pyplot and the user's backend.

    ``**kwargs`` go to ``matplotlib.figure.Figure`` (``figsize`` in inches, ``layout``, ...). The figure belongs to
    no global figure manager: nothing keeps it alive once the caller drops it, and drawing it changes no backend the
    user chose (a notebook keeps its own).

    Returns
    -------
    matplotlib.figure.Figure
        The empty figure, its canvas attached.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def subplots(*grid: int, figsize: tuple[float, float], **kwargs: Any) -> tuple[Any, Any]:
    """A figure and a grid of axes on it, as ``pyplot.subplots`` makes them, without pyplot (:func:`new_figure`).

    ``*grid`` is the grid's rows and columns (none: one axes); ``**kwargs`` go to ``Figure.subplots``
    (``sharex``, ``height_ratios``, ...).

    Parameters
    ----------
    figsize : tuple of float
        The figure's width and height, inches.

    Returns
    -------
    figure : matplotlib.figure.Figure
        The figure.
    axes : matplotlib.axes.Axes or ndarray of Axes
        One axes for a single cell, else an array of them shaped like the grid (squeezed as ``pyplot`` does).
    """
    fig = new_figure(figsize=figsize)
    return fig, fig.subplots(*grid, **kwargs)


def save_png(fig: Any, path: Path) -> None:
    """Write a figure to a PNG file at 90 dots per inch, atomically (a temporary file moved into place), drawn and
    encoded as :func:`png_bytes` does.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, drawn on an Agg canvas (:func:`new_figure`).
    path : Path
        The PNG file to write; its folder is made if missing, and a failed write leaves no half-written file.
    """
    data = png_bytes(fig, 90)
    with atomic_open(path, "wb") as fh:
        fh.write(data)


def png_bytes(fig: Any, dpi: int) -> bytes:
    """A figure as PNG bytes for a page, drawn and encoded cheaply.

    The text is drawn unhinted (FreeType's autohinter takes a third of the time text takes to draw) and the image
    encoded as opaque RGB at compression level 1 (half the time of matplotlib's RGBA at level 6, and smaller); the
    pixels are those ``savefig`` gives with unhinted text. Unhinted text is set in matplotlib's global ``rcParams``,
    so a lock lets one figure at a time be drawn in a process: threads drawing their own figures may call this at
    once.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, on an Agg canvas (:func:`new_figure`); its dpi is set to ``dpi``.
    dpi : int
        Dots per inch: the image is the figure's size in inches times this, in pixels.

    Returns
    -------
    bytes
        The PNG file's content.
    """
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
