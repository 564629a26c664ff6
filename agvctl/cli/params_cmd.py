"""``agvctl params``: the vehicle's constants and the derived ones."""

from __future__ import annotations

import argparse
import json
from typing import Any

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.config import to_dict
from agvctl.params import VehicleParams, load_vehicle


def register(sub: Any) -> None:
    p = sub.add_parser(
        "params",
        help=command_summary("params"),
        description="Show a vehicle's parameters and the constants derived from them (eq numbers).",
    )
    add_vehicle_options(p)
    p.add_argument("--json", action="store_true", help='print {"vehicle": {...}, "derived": {...}}')
    p.set_defaults(func=run)


def params_report(vehicle: VehicleParams) -> dict[str, Any]:
    """The ``--json`` object: the vehicle as in its file, and the derived constants."""
    return {"vehicle": to_dict(vehicle), "derived": vehicle.derived.as_dict()}


_DERIVED_LABELS = [
    ("inertia_from_dimensions_kg_m2", "I from frame and battery dimensions (eq 64)", "kg m²"),
    ("inertia_rotation_point_kg_m2", "I + M h², about the point of rotation (eqs 16-28)", "kg m²"),
    ("k_ll", "k_ll (eq 47)", "kg m²"),
    ("k_rr", "k_rr (eq 48)", "kg m²"),
    ("k_lr", "k_lr (eq 49)", "kg m²"),
    ("k_llr", "k_llr (eq 50)", "kg m²"),
    ("k_lrr", "k_lrr (eq 51)", "kg m²"),
    ("inertia_equivalent_left_kg_m2", "J̃_l, equivalent inertia (eq 60)", "kg m²"),
    ("inertia_equivalent_right_kg_m2", "J̃_r, equivalent inertia (eq 61)", "kg m²"),
    ("damping_left_n_m_s_rad", "damping k_e k_t/R + f_m, left (eq 1)", "N m s/rad"),
    ("damping_right_n_m_s_rad", "damping k_e k_t/R + f_m, right (eq 1)", "N m s/rad"),
    ("friction_gain_p_left", "P_l, friction gain (eq 62)", "N m s/rad"),
    ("friction_gain_p_right", "P_r, friction gain (eq 62)", "N m s/rad"),
    ("accel_limit_m_s2", "a_lim, acceleration limit (eq 5)", "m/s²"),
    ("da_volts_per_bit", "DA volts per bit", "V"),
    ("max_speed_m_s", "top speed, full DA output, friction included", "m/s"),
    ("mechanical_time_constant_s", "mechanical time constant J̃ R/(k_e k_t + f_m R)", "s"),
    ("breakaway_amplifier_voltage_left_v", "break-away motor voltage τ_s R/k_t, left", "V"),
    ("breakaway_amplifier_voltage_right_v", "break-away motor voltage τ_s R/k_t, right", "V"),
]


def format_params(vehicle: VehicleParams) -> str:
    """A readable table of the parameters and derived constants."""
    lines = [f"vehicle: {vehicle.name}", ""]
    data = to_dict(vehicle)

    def walk(prefix: str, d: dict[str, Any]) -> None:
        for k, v in d.items():
            key = f"{prefix}.{k}" if prefix else k
            if isinstance(v, dict):
                walk(key, v)
            elif key != "name":
                shown = v if isinstance(v, str) else ", ".join(v) if isinstance(v, list) else f"{v:.6g}"
                lines.append(f"  {key:<44} {shown:>14}")

    walk("", data)
    lines += ["", "derived:"]
    derived = vehicle.derived.as_dict()
    for key, label, unit in _DERIVED_LABELS:
        lines.append(f"  {label:<54} {derived[key]:>12.6g} {unit}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    vehicle = load_vehicle(args.vehicle, args.overrides)
    if args.json:
        print(json.dumps(params_report(vehicle), indent=2))
    else:
        print(format_params(vehicle))
    return 0
