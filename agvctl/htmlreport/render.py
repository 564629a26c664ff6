"""The templates and what they are filled with: the Jinja2 environment, embedded images, numbers with units."""

from __future__ import annotations

import base64
import functools
import math
from typing import Any

from agvctl.evaluation.limits import LIMITS

__all__ = ["data_uri", "limit_value", "render_template", "time_text"]


@functools.lru_cache(maxsize=1)
def _environment() -> Any:
    import jinja2

    return jinja2.Environment(
        loader=jinja2.PackageLoader("agvctl.htmlreport", "templates"),
        autoescape=True,  # every text from a report (names, paths, messages, TOML) is escaped
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def render_template(name: str, **context: Any) -> str:
    """A page's HTML text: one of the package's Jinja2 templates filled in.

    The templates are in ``agvctl/htmlreport/templates``; every text filled in is HTML-escaped (names, paths,
    messages, TOML), and a name the template uses but ``**context`` lacks is an error, not an empty string.

    Parameters
    ----------
    name : str
        The template's file name (``"check.html.j2"``, ``"fuzz.html.j2"``).

    Returns
    -------
    str
        The HTML document.
    """
    text: str = _environment().get_template(name).render(**context)
    return text


def data_uri(png: bytes) -> str:
    """A PNG image as a ``data:`` address, so that the page holds its figures and opens without other files.

    Parameters
    ----------
    png : bytes
        The PNG file's content.

    Returns
    -------
    str
        ``data:image/png;base64,`` followed by the image in base64, for an ``<img src>``.
    """
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def limit_value(limit: str, value: float | None) -> str:
    """A limit's value or bound as the page shows it: with the limit's unit, as ``agvctl check`` prints it.

    Parameters
    ----------
    limit : str
        The limit's name, a key of :data:`~agvctl.evaluation.limits.LIMITS` (its printed unit, ``" m"``, ``"°"``,
        or none); another name is printed without a unit.
    value : float or None
        The value, in the unit of the limit's name (``tracking_error_max_m``: m).

    Returns
    -------
    str
        Six significant digits and the unit (``0.0012 m``); ``—`` when the value is None or not finite.
    """
    if value is None or not math.isfinite(value):
        return "—"
    unit = LIMITS[limit].unit if limit in LIMITS else ""
    return f"{value:.6g}{unit}"


def time_text(t_s: float | None) -> str:
    """An instant as the page's limit table shows it (when a limit was worst, when it was first exceeded).

    Parameters
    ----------
    t_s : float or None
        The instant, s (None: none).

    Returns
    -------
    str
        ``t = 3.21 s`` (two decimals), or an empty string for None.
    """
    return "" if t_s is None else f"t = {t_s:.2f} s"
