"""Mass, centre of mass and moment of inertia, the report's appendix A.1 (eqs 63-64).

Three scale readings, one under each wheel, give the total mass M and, by a moment balance about the wheel
axle, the centre of mass h behind it (eq 63, :func:`agvctl.params.center_of_mass_from_scales`). The moment of
inertia about the point of rotation follows from the frame and battery dimensions (eq 64,
:func:`agvctl.params.inertia_from_dimensions`; 5.46 kg m² for the IAU AGV).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agvctl.calibration.common import Estimate
from agvctl.config import document_fields
from agvctl.params import VehicleParams, center_of_mass_from_scales, inertia_from_dimensions

__all__ = ["SCALE_NOISE_KG", "MassFit", "apply_mass", "identify_mass", "simulated_scale_readings"]

SCALE_NOISE_KG = 0.2
"""Standard deviation of one simulated scale reading at ``noise_scale = 1`` (kg): a bathroom scale."""


@document_fields
@dataclass(frozen=True)
class MassFit:
    """Total mass (eq 63's sum), centre of mass (eq 63) and moment of inertia (eq 64)."""

    mass_kg: Estimate
    """The total mass M, kg."""
    com_behind_axle_m: Estimate
    """The centre of mass h behind the wheel axle, m."""
    inertia_kg_m2: Estimate
    """The moment of inertia about the point of rotation, from the dimensions (eq 64), kg m²; its standard error
    is 0 (no measurement)."""
    readings_kg: tuple[float, float, float]
    """The scale readings under the left, right and castor wheels, kg."""

    def as_dict(self) -> dict[str, dict[str, float | None]]:
        """The ``--json`` object: ``{"mass_kg", "com_behind_axle_m", "inertia_kg_m2"}``, each an estimate."""
        return {
            "mass_kg": self.mass_kg.as_dict(),
            "com_behind_axle_m": self.com_behind_axle_m.as_dict(),
            "inertia_kg_m2": self.inertia_kg_m2.as_dict(),
        }


def simulated_scale_readings(
    vehicle: VehicleParams, *, noise_scale: float = 0.0, seed: int | None = None
) -> tuple[float, float, float]:
    """The readings three scales would show under a vehicle, one under each wheel.

    Moment balance about the wheel axle: M_c = M h/d_wc, M_l = M_r = (M − M_c)/2 (the mass symmetric left to
    right, as the report assumes), each plus white noise.

    Parameters
    ----------
    vehicle : VehicleParams
        The simulated vehicle.
    noise_scale : float
        The noise of each reading in units of :data:`SCALE_NOISE_KG` (0: none).
    seed : int or None
        The noise's seed.

    Returns
    -------
    tuple of float
        The readings under the left, right and castor wheels, kg.

    Raises
    ------
    ValueError
        A negative or non-finite ``noise_scale``.
    """
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be >= 0 (got {noise_scale})")
    m, h, d = vehicle.body.mass_kg, vehicle.body.com_behind_axle_m, vehicle.frame.wheel_axis_to_castor_m
    castor = m * h / d
    readings = np.array([(m - castor) / 2.0, (m - castor) / 2.0, castor])
    if noise_scale > 0:
        readings = readings + np.random.default_rng(seed).normal(0.0, noise_scale * SCALE_NOISE_KG, 3)
    return float(readings[0]), float(readings[1]), float(readings[2])


def identify_mass(
    vehicle: VehicleParams,
    mass_left_kg: float,
    mass_right_kg: float,
    mass_castor_kg: float,
    *,
    scale_stderr_kg: float = 0.0,
    truth: VehicleParams | None = None,
) -> MassFit:
    """M and h from three scale readings (eq 63), and I from the vehicle's dimensions (eq 64).

    Standard errors propagate one reading's σ (the readings independent): σ_M = √3 σ and
    σ_h = d_wc/M² · √((M − M_c)² + 2 M_c²) σ.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle weighed: its distance d_wc from the wheel axle to the castor, and its frame and battery.
    mass_left_kg, mass_right_kg : float
        The readings under the left and right wheels, kg.
    mass_castor_kg : float
        The reading under the castor, kg.
    scale_stderr_kg : float
        One reading's standard error σ, kg.
    truth : VehicleParams or None
        The true vehicle, on the simulator: its values go into the estimates' ``truth``.

    Returns
    -------
    MassFit
        M, h and I with their standard errors.

    Raises
    ------
    ValueError
        Negative or non-finite readings, or readings that sum to zero.

    Examples
    --------
    >>> from agvctl.params import load_vehicle
    >>> fit = identify_mass(load_vehicle(), 36.0, 36.0, 13.0, scale_stderr_kg=0.2)
    >>> print(f"M = {fit.mass_kg.estimate:g} kg, h = {fit.com_behind_axle_m.estimate * 1e3:.1f} mm")
    M = 85 kg, h = 76.5 mm
    """
    d = vehicle.frame.wheel_axis_to_castor_m
    total, h = center_of_mass_from_scales(mass_left_kg, mass_right_kg, mass_castor_kg, d)  # eq 63
    if not math.isfinite(total * total):
        raise ValueError(f"the scale readings are too large to add up (total {total:g} kg)")
    sigma = scale_stderr_kg
    se_m = math.sqrt(3.0) * sigma
    se_h = d / total**2 * math.sqrt((total - mass_castor_kg) ** 2 + 2.0 * mass_castor_kg**2) * sigma
    inertia = inertia_from_dimensions(vehicle.frame, vehicle.battery)  # eq 64
    true_inertia = None if truth is None else inertia_from_dimensions(truth.frame, truth.battery)
    return MassFit(
        mass_kg=Estimate(total, se_m, None if truth is None else truth.body.mass_kg),
        com_behind_axle_m=Estimate(h, se_h, None if truth is None else truth.body.com_behind_axle_m),
        inertia_kg_m2=Estimate(inertia, 0.0, true_inertia),
        readings_kg=(mass_left_kg, mass_right_kg, mass_castor_kg),
    )


def apply_mass(vehicle: VehicleParams, fit: MassFit) -> VehicleParams:
    """A vehicle with M, h and I identified.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle to update.
    fit : MassFit
        The identified values.

    Returns
    -------
    VehicleParams
        A copy with them; I is written as its ``body.inertia_about`` expects: eq 64's value about the point of
        rotation, or I − M h² about the centre of mass.
    """
    m, h = fit.mass_kg.estimate, fit.com_behind_axle_m.estimate
    inertia = fit.inertia_kg_m2.estimate
    if vehicle.body.inertia_about == "center_of_mass":
        inertia -= m * h**2
    return vehicle.with_overrides(
        [("body.mass_kg", m), ("body.com_behind_axle_m", h), ("body.inertia_kg_m2", inertia)],
        source="identified mass",
    )
