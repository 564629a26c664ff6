"""``agvctl simulate``: open-loop response to DA voltages (placeholder until the simulator lands)."""

from __future__ import annotations

from typing import Any


def register(sub: Any) -> None:
    pass
