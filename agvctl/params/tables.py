"""The tables of a vehicle file that come once per vehicle (the report's appendix A), one frozen dataclass each,
and the moments of inertia that follow from the frame, battery and body.

The tables that come once per side, wheels and motors, are in :mod:`agvctl.params.sides`;
:class:`~agvctl.params.VehicleParams` holds them all.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from agvctl.config import check_fields, document_fields, number
from agvctl.errors import ConfigError
from agvctl.params.ranges import check_ranges, physical

__all__ = [
    "AmplifierParams",
    "BatteryParams",
    "BodyParams",
    "ControlParams",
    "DAParams",
    "FrameParams",
    "FrictionModelParams",
    "SensorParams",
    "inertia_from_dimensions",
    "inertia_rotation_point",
]

InertiaAbout = Literal["rotation_point", "center_of_mass"]

_SIZE_M = (1e-3, 100.0, "a millimetre to a hundred metres")
"""The physically possible range of a vehicle's lengths (m), and its reason."""
_MASS_KG = (1e-3, 1e6, "a gram to a thousand tonnes")
"""The physically possible range of its masses (kg), and its reason."""


@document_fields
@dataclass(frozen=True)
class FrameParams:
    """The vehicle frame (appendix A, "Frame dimensions")."""

    length_m: float = physical(*_SIZE_M, gt=0, doc="Its length, front to back, m.")
    width_m: float = physical(*_SIZE_M, gt=0, doc="Its width, m.")
    height_m: float = physical(*_SIZE_M, gt=0, doc="Its height, m.")
    mass_kg: float = physical(*_MASS_KG, gt=0, doc="Its mass M_f, kg.")
    front_to_rotation_point_m: float = physical(
        0.0, _SIZE_M[1], _SIZE_M[2], ge=0, doc="d_of, from the front to the point of rotation (l_of in eq 64), m."
    )
    wheel_axis_to_castor_m: float = physical(*_SIZE_M, gt=0, doc="d_wc, from the wheel axle to the castor (eq 63), m.")

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class BatteryParams:
    """The battery block, centred over the point of rotation (appendix A.1)."""

    length_m: float = physical(*_SIZE_M, gt=0, doc="Its length l_b, m.")
    width_m: float = physical(*_SIZE_M, gt=0, doc="Its width w_b, m.")
    height_m: float = physical(*_SIZE_M, gt=0, doc="Its height, m.")
    mass_kg: float = physical(*_MASS_KG, gt=0, doc="Its mass M_b, kg.")

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class BodyParams:
    """The whole vehicle as one rigid body: total mass M, moment of inertia I and centre of mass h behind the
    wheel axle."""

    mass_kg: float = physical(*_MASS_KG, gt=0, doc="The total mass M, kg.")
    inertia_kg_m2: float = physical(
        1e-9,
        1e10,
        "a gram at a millimetre to a thousand tonnes at a hundred metres",
        gt=0,
        doc="The moment of inertia I about the vertical axis, kg m².",
    )
    com_behind_axle_m: float = physical(
        -_SIZE_M[1], _SIZE_M[1], _SIZE_M[2], doc="h, how far the centre of mass lies behind the wheel axle, m."
    )
    inertia_about: InertiaAbout = "rotation_point"
    """The point ``inertia_kg_m2`` is about: the point of rotation (the report's table: it already is I + M h²) or
    the centre of mass (the literal eq 12; model note 6)."""

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class AmplifierParams:
    """The power amplifier: gain k_pow, and its voltage and current limits (model note 9, docs/model-notes.md)."""

    gain: float = physical(
        1e-3, 1e4, "a thousandth to ten thousand volts per volt", gt=0, doc="k_pow, motor volts per DA volt."
    )
    current_limit_a: float = physical(
        1e-4,
        1e5,
        "a micro-motor's 0.1 mA to a traction drive's 100 kA",
        gt=0,
        doc="I_max, the armature current it holds each motor to, A.",
    )
    voltage_limit_v: float = physical(
        1e-3, 1e5, "a millivolt to a hundred kilovolts", gt=0, doc="u_max, the largest motor voltage it gives, V."
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class DAParams:
    """The DA converter: output range and resolution."""

    min_v: float = physical(
        -1e4, 1e4, "a converter's output, within ten kilovolts", doc="The output of the lowest code, V."
    )
    max_v: float = physical(
        -1e4,
        1e4,
        "a converter's output, within ten kilovolts",
        doc="The top of the output range (one code above the highest code's output), V.",
    )
    bits: int = number(gt=0, le=32, doc="Its resolution: 2**bits codes over the range.")

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)
        if not self.min_v < self.max_v:
            raise ConfigError(
                type(self).__name__, "min_v", f"must be below max_v (got {self.min_v:g} >= {self.max_v:g})"
            )

    @property
    def volts_per_code(self) -> float:
        """alpha_DA = (max_v - min_v) / 2**bits (10 V / 4096 = 2.44140625e-3 V for the default)."""
        return float(self.max_v - self.min_v) / float(1 << self.bits)

    @property
    def code_min(self) -> int:
        return -(1 << (self.bits - 1))

    @property
    def code_max(self) -> int:
        return (1 << (self.bits - 1)) - 1

    @property
    def mid_v(self) -> float:
        return 0.5 * (self.min_v + self.max_v)


@document_fields
@dataclass(frozen=True)
class FrictionModelParams:
    """The pre-velocity friction model's gain factor: P = p_factor * (k_e k_t + f_m R) / R (eq 62)."""

    p_factor: float = number(
        gt=0, default=10.0, doc="The factor: 10 to 100 in the report; 10 keeps the simulation fast."
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class ControlParams:
    """Digital control: the sample period T_s."""

    sample_period_s: float = number(ge=1e-4, le=1.0, doc="T_s, the control loops' sample period, s.")

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


@document_fields
@dataclass(frozen=True)
class SensorParams:
    """The vehicle's sensors (docs/guide/estimation.md): incremental encoders on the motor shafts, an
    optional rate gyro, and absolute position fixes from a beacon/laser system. Under ``[plant] set`` these are
    the true sensors; in the vehicle file they are what the estimators believe."""

    encoder_counts_per_rev: int = physical(
        1, 2**31, "a counter of 32 bits", gt=0, default=2000, doc="Counts per motor revolution after quadrature."
    )
    gyro_enabled: bool = False
    """Whether the vehicle carries the rate gyro."""
    gyro_sigma_rad_s: float = physical(
        0.0,
        100.0,
        "a gyro's noise, below 100 rad/s",
        ge=0,
        default=0.002,
        doc="White noise of each sample's mean rate, rad/s.",
    )
    gyro_bias_rad_s: float = physical(
        -100.0, 100.0, "a gyro's bias, within 100 rad/s", default=0.0, doc="Constant bias of the gyro's reading, rad/s."
    )
    gyro_quantum_rad_s: float = physical(
        0.0,
        100.0,
        "a gyro's step, below 100 rad/s",
        ge=0,
        default=0.0008,
        doc="Resolution of the gyro's reading (0: none), rad/s.",
    )
    position_fix_rate_hz: float = number(ge=0, default=4.0, doc="Position fixes per second (0: none), Hz.")
    position_fix_sigma_m: float = physical(
        1e-9, 1e4, "a nanometre to ten kilometres", gt=0, default=0.01, doc="Standard deviation of a fix's x and y, m."
    )
    heading_fix_sigma_deg: float = physical(
        1e-9, 180.0, "at most half a turn", gt=0, default=0.5, doc="Standard deviation of a fix's heading, °."
    )
    position_fix_latency_s: float = number(
        ge=0, le=10.0, default=0.05, doc="From a fix's measurement to its arrival at the controller, s."
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


def inertia_from_dimensions(frame: FrameParams, battery: BatteryParams) -> float:
    """Moment of inertia about the point of rotation from the frame and battery dimensions, eq 64.

    I = M_f (l² + w²)/12 + M_f (l/2 − l_of)² + M_b (l_b² + w_b²)/12: frame mass spread over its floor, battery
    mass over its bottom sheet and centred above the point of rotation.

    Parameters
    ----------
    frame : FrameParams
        The frame: its mass, length, width and how far the point of rotation is from its front.
    battery : BatteryParams
        The battery: its mass, length and width.

    Returns
    -------
    float
        I, kg m²: 5.46 kg m² for the IAU AGV.
    """
    m_f, length, w, l_of = frame.mass_kg, frame.length_m, frame.width_m, frame.front_to_rotation_point_m
    m_b, l_b, w_b = battery.mass_kg, battery.length_m, battery.width_m
    i_frame = m_f * (length**2 + w**2) / 12.0 + m_f * (length / 2.0 - l_of) ** 2  # eq 64, I_f
    i_battery = m_b * (l_b**2 + w_b**2) / 12.0  # eq 64, I_b
    return i_frame + i_battery


def inertia_rotation_point(body: BodyParams) -> float:
    """I + M h², the inertia about the point of rotation that eqs 16-28 use (model note 6, docs/model-notes.md).

    Parameters
    ----------
    body : BodyParams
        The body: its inertia, and the point that inertia is about.

    Returns
    -------
    float
        The inertia about the point of rotation, kg m².
    """
    if body.inertia_about == "rotation_point":
        return body.inertia_kg_m2  # the table's 5.46 kg m² is about O: it already is I + M h²
    return body.inertia_kg_m2 + body.mass_kg * body.com_behind_axle_m**2  # literal eq 12: I about the CoM
