"""The physically possible range of each number of a vehicle: declared once with its field, checked on construction.

A vehicle's number outside its range is no vehicle at all: a 1e-300 Ω armature, a 1e308 kg body, a 1e-9 m
frame. The ranges are wide (from a palm-sized robot to a thousand-tonne transporter) and hard: unlike the rules
between numbers (:mod:`agvctl.params.rules`), a vehicle file cannot accept one away. Within them every derived
constant (eqs 5, 47-51, 60-64) is a finite number, so a refusal always names the key that is out of range, never
"an overflow" in a constant computed from it.

:func:`physical` declares such a field (its ``doc`` gets the range and the reason, so the generated
``Parameters`` section shows them), :func:`check_ranges` checks an instance from its ``__post_init__``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from agvctl.config import number
from agvctl.errors import ConfigError

__all__ = ["check_ranges", "physical"]


def physical(
    low: float,
    high: float,
    why: str,
    *,
    doc: str,
    gt: float | None = None,
    ge: float | None = None,
    default: Any = dataclasses.MISSING,
) -> Any:
    """A :func:`~agvctl.config.number` field with a physically possible range ``[low, high]``.

    ``gt`` / ``ge`` keep the field's sign rule (checked first, as for any number); the range is checked by
    :func:`check_ranges` and refused with ``why``.

    Parameters
    ----------
    low, high : float
        The range, in the field's unit.
    why : str
        Why a value beyond it is no vehicle (shown in the message and the documentation).
    doc : str
        The field's description.
    gt, ge : float or None
        The sign rule (:func:`~agvctl.config.number`'s).
    default : object
        The field's default; without one the field is required.

    Returns
    -------
    dataclasses.Field
        The field, its range in its metadata.
    """
    field = number(gt=gt, ge=ge, default=default, doc=f"{doc} Physically possible: {low:g} … {high:g} ({why}).")
    metadata = {**field.metadata, "range": (low, high, why)}
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def check_ranges(obj: Any) -> None:
    """Check each :func:`physical` field of a dataclass against its range (after :func:`~agvctl.config.check_fields`).

    Parameters
    ----------
    obj : object
        The dataclass instance.

    Raises
    ------
    ConfigError
        ``"<Class>: <field>: must be within [low, high] (<why>) (got <value>)"``.
    """
    for f in dataclasses.fields(obj):
        bounds = f.metadata.get("range")
        if bounds is None:
            continue
        low, high, why = bounds
        value = getattr(obj, f.name)
        if not low <= value <= high:
            raise ConfigError(type(obj).__name__, f.name, f"must be within [{low:g}, {high:g}] ({why}) (got {value:g})")
