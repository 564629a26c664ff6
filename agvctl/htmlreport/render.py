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
    """The template ``name`` of ``agvctl/htmlreport/templates`` filled with ``context``."""
    text: str = _environment().get_template(name).render(**context)
    return text


def data_uri(png: bytes) -> str:
    """``png`` as a ``data:image/png;base64,…`` address, embedded in the page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def limit_value(limit: str, value: float | None) -> str:
    """``value`` with the limit's unit, as ``check`` prints it (``0.0012 m``); ``—`` when there is none."""
    if value is None or not math.isfinite(value):
        return "—"
    unit = LIMITS[limit].unit if limit in LIMITS else ""
    return f"{value:.6g}{unit}"


def time_text(t_s: float | None) -> str:
    """``t = 3.21 s``, or empty."""
    return "" if t_s is None else f"t = {t_s:.2f} s"
