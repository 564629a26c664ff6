"""The LTV MPC's QP step as generated C99: the initial error, every block's writes and the solve.

What :meth:`LtvMpcController._solve <agvctl.controllers.mpc.ltv.LtvMpcController>` computes in Python, rendered from
the QP's own parts: each block (:attr:`~agvctl.controllers.mpc.qp_blocks.QpBlock.c_step`), the error frame and the
prediction model names a template in ``templates/step/`` that writes what its Python writes, in the same order and with
the same arithmetic. A QP holding a part without C has no step in C (:func:`generate_step_c` says which).

What varies with the reference is data, the *tables*: the reference's pose, wheel speeds and feed-forward on the
horizon grid, and each block's precompute (:meth:`~agvctl.controllers.mpc.qp_blocks.QpBlock.c_tables`), computed in
Python at each reset and handed to C as pointers (:class:`~agvctl.controllers.mpc.c_step_loop.CompiledController`).
What a step keeps for the next (the QP's vectors, the matrices' varying values, which window's matrices the solver
holds, the coupling's heading) is one state structure the caller owns. The step is compiled into the library of the
QP's generated solver (:mod:`~agvctl.controllers.mpc.c_qp`), which it calls.

Every product is summed in index order on both sides (A_0 x_0 too, which Python computes in plain floats rather than
with BLAS, whose order and fused multiply-adds are the machine's), so that C and Python write the same bits.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.qp_blocks import BlockQp, QpBlock
from agvctl.errors import AgvctlError
from agvctl.plant.codegen import c_templates

__all__ = [
    "REFERENCE_TABLES",
    "MpcPartC",
    "StepC",
    "StepParts",
    "generate_step_c",
    "generate_step_tables_c",
    "reference_tables",
    "step_tables",
]

FloatArray = NDArray[np.float64]

PREFIX = "agv_mpc_step"
"""The step's stem and the prefix of the names it defines."""

REFERENCE_TABLES = (
    "x",
    "y",
    "theta",
    "cos_theta",
    "sin_theta",
    "wheel_left",
    "wheel_right",
    "feedforward",
    "speed",
    "yaw_rate",
    "travel",
    "sizes",
)
"""The reference's own tables, first of all: its pose, cos θ and sin θ, and wheel speeds at the grid points, the
feed-forward of each interval (left, right), its speed, yaw rate and travel at the grid points, and its sizes (the last
window start, the grid points)."""


def reference_tables(grid: HorizonReference) -> list[FloatArray]:
    """The reference's tables on ``grid``, in the order of :data:`REFERENCE_TABLES`.

    Parameters
    ----------
    grid : HorizonReference
        The reference on the horizon grid.

    Returns
    -------
    list of ndarray
        One-dimensional arrays of double.
    """
    return [
        grid.x_m,
        grid.y_m,
        grid.theta_rad,
        grid.cos_theta,
        grid.sin_theta,
        grid.wheel_m_s[:, 0],
        grid.wheel_m_s[:, 1],
        grid.feedforward_m_s.ravel(),
        grid.speed_m_s,
        grid.yaw_rate_rad_s,
        grid.travel_m,
        np.array([grid.last_start, grid.n_points], dtype=np.float64),
    ]


@dataclass(frozen=True)
class StepParts:
    """What a QP step is generated from: the QP and the controller's strategies and constants.

    Parameters
    ----------
    qp : BlockQp
        The assembled QP (its blocks bound).
    frame : object
        The error frame (``c_step``; :mod:`~agvctl.controllers.mpc.error_frames`).
    model : object
        The prediction model (``c_step``, ``n_states``; :mod:`~agvctl.controllers.mpc.prediction`).
    horizon : int
        N.
    sample_period_s : float
        T_s, s.
    max_wheel_speed_m_s : float
        v_max, the controller's speed limit, m/s.
    relinearise_rad : float
        How far the heading error moves before the coupling is linearised again, rad.
    """

    qp: BlockQp[Any, Any]
    frame: Any
    model: Any
    horizon: int
    sample_period_s: float
    max_wheel_speed_m_s: float
    relinearise_rad: float


@dataclass(frozen=True)
class _Part:
    id: str
    c_step: str
    v: dict[str, Any]
    first_row: int
    n_rows: int
    t: dict[str, str]
    has_write: bool
    has_matrices: bool
    has_start: bool
    template: str | None = None
    state: str = ""
    code: str = ""


@dataclass(frozen=True)
class MpcPartC:
    """The generated C of one part of the MPC's step (the QP's step, the controller's around it).

    Parameters
    ----------
    files : dict of str to str
        ``<prefix>.h`` and ``<prefix>.c``.
    prefix : str
        The stem and the names' prefix.
    horizon : int
        N.
    """

    files: dict[str, str]
    prefix: str
    horizon: int


@dataclass(frozen=True)
class StepC(MpcPartC):
    """The generated C of one QP's step (:class:`MpcPartC`), and the tables it reads.

    Parameters
    ----------
    files : dict of str to str
        ``<prefix>.h`` and ``<prefix>.c``.
    prefix : str
        The stem and the names' prefix.
    horizon : int
        N.
    table_names : tuple of str
        The tables in the order the step reads them: the reference's, then ``<block>.<name>`` for each block's.
    """

    table_names: tuple[str, ...] = ()


def _identifier(name: str) -> str:
    return name.replace(" ", "_").replace("-", "_")


def _parts(parts: StepParts, macro: str) -> tuple[list[_Part], list[dict[str, str]]]:
    """The C parts in order (frame, model, the blocks in row order) and the table list after the reference's."""
    qp, tables = parts.qp, []
    missing = [b.name for b in qp.blocks if b.c_step is None and b.c_template is None]
    if missing:
        raise AgvctlError(f"the QP step has no C for {', '.join(missing)}")
    half = 0.5 * parts.sample_period_s
    result = [
        _Part("frame", parts.frame.c_step, {"half_period": half}, 0, 0, {}, False, False, False),
        _Part("model", parts.model.c_step, {"relinearise": parts.relinearise_rad}, 0, 0, {}, False, False, False),
    ]
    for block in qp.blocks:
        ident = _identifier(block.name)
        t = {}
        for name in block.c_tables_names:
            t[name] = f"{macro}_TABLE_{ident.upper()}_{name.upper()}"
            tables.append({"macro": f"{ident.upper()}_{name.upper()}", "doc": f"{block.name}: {name}"})
        rows = qp.rows[block.name]
        has_write = type(block).write is not QpBlock.write
        has_matrices = type(block).write_matrices is not QpBlock.write_matrices
        result.append(
            _Part(
                ident,
                block.c_step or "",
                block.c_values(qp),
                rows.start,
                block.n_rows,
                t,
                has_write,
                has_matrices,
                False,
                block.c_template,
            )
        )
    return result, tables


def generate_step_c(
    parts: StepParts, *, origin: str, generator: str, prefix: str = PREFIX, qp_prefix: str = "agv_mpc_qp"
) -> StepC:
    """The C99 of a QP's step (see the module's description).

    Parameters
    ----------
    parts : StepParts
        The QP, the strategies and the constants.
    origin : str
        What the QP is of, written into the files.
    generator : str
        What wrote them.
    prefix : str
        The step's stem and the names' prefix.
    qp_prefix : str
        The prefix of the QP's generated solver (:func:`~agvctl.controllers.mpc.c_qp.generate_qp_c`).

    Returns
    -------
    StepC
        The files.

    Raises
    ------
    AgvctlError
        A block has no C.
    """
    import osqp

    macro = prefix.upper()
    c_parts, block_tables = _parts(parts, macro)
    env = c_templates("agvctl.controllers.mpc")
    reference = [{"macro": f"REFERENCE_{name.upper()}", "doc": f"the reference: {name}"} for name in REFERENCE_TABLES]
    qp = parts.qp
    values: dict[str, Any] = {
        "prefix": prefix,
        "qp_prefix": qp_prefix,
        "guard": f"{macro}_H",
        "macro": macro,
        "origin": origin,
        "generator": generator,
        "block_names": [b.name for b in qp.blocks],
        "frame": parts.frame.c_step,
        "model": parts.model.c_step,
        "horizon": parts.horizon,
        "nx": parts.model.n_states,
        "n": qp.layout.n_variables,
        "m": qp.n_rows,
        "n_p": len(qp.p_varying),
        "n_a": len(qp.a_varying),
        "tables": reference + block_tables,
        "n_tables": len(reference) + len(block_tables),
        "pi": math.pi,
        "max_speed": parts.max_wheel_speed_m_s,
        "first_setpoint": qp.layout.start("setpoints"),
        "solved": int(osqp.SolverStatus.OSQP_SOLVED),
        "solved_inaccurate": int(osqp.SolverStatus.OSQP_SOLVED_INACCURATE),
    }
    rendered = []
    for part in c_parts:  # each part's state fields and code; it has a start where its code defines one
        template = env.from_string(part.template) if part.template else env.get_template(f"step/{part.c_step}.c.j2")
        state = template.render({**values, "part": part, "section": "state"})
        code = template.render({**values, "part": part, "section": "code"})
        rendered.append(dataclasses.replace(part, state=state, code=code, has_start=f"{part.id}_start(" in code))
    values["parts"] = rendered
    files = {
        f"{prefix}.h": env.get_template("mpc_step.h.j2").render(values),
        f"{prefix}.c": env.get_template("mpc_step.c.j2").render(values),
    }
    names = (*REFERENCE_TABLES, *(f"{b.name}.{n}" for b in qp.blocks for n in b.c_tables_names))
    return StepC(files, prefix, parts.horizon, names)


def step_tables(qp: BlockQp[Any, Any], grid: HorizonReference) -> list[FloatArray]:
    """The tables of the present reference, in the order of :attr:`StepC.table_names` (contiguous copies where a
    table is a strided view).

    Parameters
    ----------
    qp : BlockQp
        The QP, its blocks retargeted to the reference.
    grid : HorizonReference
        The reference on the horizon grid.

    Returns
    -------
    list of ndarray
        The reference's own (:func:`reference_tables`), then each block's (``QpBlock.c_tables``).
    """
    tables = reference_tables(grid)
    for block in qp.blocks:
        given = block.c_tables()
        if tuple(given) != block.c_tables_names:
            raise AgvctlError(f"block {block.name!r} gives the tables {list(given)}, not {list(block.c_tables_names)}")
        tables.extend(given.values())
    return [np.ascontiguousarray(t, dtype=np.float64).ravel() for t in tables]


def _table_values(code: StepC, tables: Sequence[FloatArray]) -> list[dict[str, Any]]:
    """One reference's tables as the tables' template takes them (their names and values), checked."""
    if len(tables) != len(code.table_names):
        raise AgvctlError(f"the QP step reads {len(code.table_names)} tables, given {len(tables)}")
    values = []
    for name, table in zip(code.table_names, tables, strict=True):
        if not np.all(np.isfinite(table) | np.isinf(table)):
            raise AgvctlError(f"the QP step's table {name!r} holds NaN")
        values.append({"doc": name, "data": [float(v) for v in table]})
    return values


def generate_step_tables_c(
    code: StepC,
    qp: BlockQp[Any, Any],
    tables: Sequence[FloatArray],
    last_start: int,
    *,
    rho: float,
    origin: str,
    generator: str,
    qp_prefix: str = "agv_mpc_qp",
    manoeuvres: Sequence[tuple[Sequence[FloatArray], float] | None] = (),
    first_steps: int = 0,
) -> dict[str, str]:
    """One reference's tables as static C data beside a step (``<prefix>_tables.{h,c}``): the arrays, the array of
    their addresses the step reads, and a start of the reference as the controller's reset (the QP's vectors and
    varying entries as set up, the solver from zero with its step size).

    Parameters
    ----------
    code : StepC
        The step.
    qp : BlockQp
        The QP, retargeted to the reference (its vectors as set up: the fixed rows' bounds and costs).
    tables : sequence of ndarray
        The reference's tables (:func:`step_tables`).
    last_start : int
        The reference's last window start.
    rho : float
        The solver's step size as set up, which a start of the reference sets again (as the controller's reset).
    origin : str
        What the reference is, written into the files.
    generator : str
        What wrote them.
    qp_prefix : str
        The prefix of the QP's generated solver.
    manoeuvres : sequence of (sequence of ndarray, float) or None
        The docking manoeuvres' tables and durations (s), by the steps they back up from ``first_steps`` on (None: no
        manoeuvre for those steps); none: no docking.
    first_steps : int
        The steps the first manoeuvre backs up.

    Returns
    -------
    dict of str to str
        ``{file name: text}``.

    Raises
    ------
    AgvctlError
        The tables are not the step's, or hold a NaN.
    """
    macro = code.prefix.upper()
    start = {"q": qp.q, "l": qp.lower, "u": qp.upper, "p": qp.p_data[qp.p_varying], "a": qp.a_data[qp.a_varying]}
    values = {
        "prefix": code.prefix,
        "macro": macro,
        "guard": f"{macro}_TABLES_H",
        "origin": origin,
        "generator": generator,
        "last_start": last_start,
        "rho": rho,
        "qp_prefix": qp_prefix,
        "n": qp.layout.n_variables,
        "m": qp.n_rows,
        "tables": _table_values(code, tables),
        "start": [(name, [float(v) for v in vector]) for name, vector in start.items()],
        "first_steps": first_steps,
        "manoeuvres": [
            None if m is None else {"steps": first_steps + i, "duration": m[1], "tables": _table_values(code, m[0])}
            for i, m in enumerate(manoeuvres)
        ],
    }
    env = c_templates("agvctl.controllers.mpc")
    return {
        f"{code.prefix}_tables.h": env.get_template("mpc_step_tables.h.j2").render(values),
        f"{code.prefix}_tables.c": env.get_template("mpc_step_tables.c.j2").render(values),
    }
