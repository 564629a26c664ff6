"""Benchmark of a faster QP algorithm for the MPC: the LTV MPC's QP condensed and solved by DAQP, against OSQP.

The figure-8 experiment's closed loop runs with its MPC on OSQP; at every solve the QP as OSQP holds it is kept
(P, A, q, l, u from :attr:`~agvctl.controllers.mpc.ltv.LtvMpcController.qp`), with OSQP's solution and the C solve
time OSQP reports (``info.run_time``: its setup-free solve, no Python). Each kept QP is then condensed, the error
states eliminated through the dynamics rows (the equality rows), leaving a dense QP in the setpoints and the reversal
slacks, and solved by DAQP, a dense dual active-set solver, warm-started from the previous step's active set (the
constraints its multipliers marked, at their upper or lower bound), timed by DAQP's own ``setup_time`` (it
factorises H and prepares the constraints) and ``solve_time`` (the active-set iterations), C with no Python. The
condensing is done here with dense numpy and is not timed: in C it is the prediction matrices' products.

The steps are told apart by whether the QP's matrices changed since the step before: where they did not, OSQP
solves with its factorisation and DAQP needs no new set-up (its Python interface sets up every call, so only its
solve time is counted); where they did, OSQP refactorises in its update and DAQP sets up anew. Prints, for each
kind of step, both solvers' median and p99 times and the ratio, and DAQP's iterations and how far its first
setpoints lie from OSQP's (OSQP solves to ε = 10⁻³).

Needs DAQP, which agvctl does not depend on: ``pip install daqp``.

Run:  python experiments/benchmarks/mpc_qp_daqp.py
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENT = Path(__file__).parents[1] / "figure8.toml"
INFINITE = 1e29
"""A bound at least this large is none (OSQP's infinity is 10³⁰)."""


class Keeping:
    """The controller's OSQP solver, keeping the QP and the answer of every solve."""

    def __init__(self, solver: Any, controller: LtvMpcController) -> None:
        self.solver, self.controller = solver, controller
        self.kept: list[tuple[Any, ...]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.solver, name)

    def solve(self, raise_error: bool = False) -> Any:
        result = self.solver.solve(raise_error=raise_error)
        qp = self.controller.qp
        a, p = qp.A.copy(), qp.P.copy()
        a.data, p.data = qp.a_data.copy(), qp.p_data.copy()
        self.kept.append((p, a, qp.q.copy(), qp.lower.copy(), qp.upper.copy(), result.x.copy(), result.info.run_time))
        return result


def condensed(p: Any, a: Any, q: Any, lower: Any, upper: Any, n_states: int) -> tuple[Any, ...]:
    """The QP in the inputs alone: z = T v + t from the equality rows, the cost and the other bounded rows in v."""
    a = a.tocsr()
    full_p = (p + sp.triu(p, 1).T).toarray()
    equal = np.flatnonzero(lower == upper)
    bounded = np.flatnonzero((lower != upper) & ((lower > -INFINITE) | (upper < INFINITE)))
    e = a[equal].toarray()
    e_states_inverse = np.linalg.inv(e[:, :n_states])
    n_inputs = a.shape[1] - n_states
    t_map = np.vstack([-e_states_inverse @ e[:, n_states:], np.eye(n_inputs)])
    t_offset = np.concatenate([e_states_inverse @ lower[equal], np.zeros(n_inputs)])
    rows = a[bounded].toarray()
    h = t_map.T @ full_p @ t_map
    f = t_map.T @ (full_p @ t_offset + q)
    shift = rows @ t_offset
    return h, f, rows @ t_map, upper[bounded] - shift, lower[bounded] - shift, t_map, t_offset


def main() -> None:
    try:
        import daqp
    except ImportError:
        raise SystemExit("this benchmark needs DAQP: pip install daqp") from None
    experiment = load_experiment(EXPERIMENT)
    controller = LtvMpcController(experiment.controller_vehicle, experiment.spec.controller.pose_settings)
    keeping = Keeping(controller._solver, controller)
    controller._solver = keeping
    run_experiment(experiment, pose_controller=controller)
    n_states = controller.qp.layout.start("setpoints")
    i_first = n_states  # the first sample's two setpoints follow the states
    daqp_s, osqp_s, changed, iterations, setpoint_gap = [], [], [], [], []
    sense, previous = None, None
    for p, a, q, lower, upper, z_osqp, osqp_time_s in keeping.kept:
        same = previous is not None and np.array_equal(previous[0], p.data) and np.array_equal(previous[1], a.data)
        previous = (p.data, a.data)
        changed.append(not same)
        h, f, rows, b_upper, b_lower, t_map, t_offset = condensed(p, a, q, lower, upper, n_states)
        if sense is None or len(sense) != len(b_upper):
            sense = np.zeros(len(b_upper), dtype=np.int32)
        v, _, flag, info = daqp.solve(h, f, rows, b_upper, b_lower, sense)
        if flag < 1:
            raise SystemExit(f"DAQP failed on a step (exit flag {flag})")
        z = t_map @ v + t_offset
        daqp_s.append(info["solve_time"] + (info["setup_time"] if not same else 0.0))
        osqp_s.append(osqp_time_s)
        iterations.append(info["iterations"])
        setpoint_gap.append(float(np.max(np.abs(z[i_first : i_first + 2] - z_osqp[i_first : i_first + 2]))))
        multipliers = np.asarray(info["lam"])
        sense = np.where(multipliers > 0, 1, np.where(multipliers < 0, 3, 0)).astype(np.int32)  # 1 upper, 1|2 lower
    d, o, new = np.array(daqp_s) * 1e6, np.array(osqp_s) * 1e6, np.array(changed)
    print(f"figure-8, {len(d)} solves; condensed QP: {h.shape[0]} variables, {len(b_upper)} bounded rows")
    for label, where in (("matrices unchanged", ~new), ("matrices changed", new)):
        od, dd = o[where], d[where]
        print(f"  {label} ({int(where.sum())} steps):")
        for name, times in (("OSQP (update, solve)", od), ("DAQP (set-up if new, solve)", dd)):
            print(f"    {name:28s} median {np.median(times):6.1f} µs, p99 {np.percentile(times, 99):6.1f} µs")
        print(f"    ratio of medians OSQP/DAQP: {np.median(od) / np.median(dd):.2f}")
    print(f"  DAQP iterations median {np.median(iterations):g}")
    gap = np.array(setpoint_gap)
    print(f"  first setpoints, DAQP against OSQP: largest {gap.max():.2g} m/s, median {np.median(gap):.2g} m/s")


if __name__ == "__main__":
    main()
