"""A quadratic program built from named blocks, set up once and updated in place.

The problem is OSQP's::

    minimise  ½ zᵀPz + qᵀz   subject to  l ≤ Az ≤ u

with P's upper triangle. Variable blocks (:class:`VariableBlock`) name slices of z. Each QP block
(:class:`QpBlock`) owns one part of the problem:

* the variables it introduces and its constraint rows, laid out by :class:`BlockQp` in the order of the blocks;
* its entries of A (in its own rows) and of P — its sparsity pattern — with the entries whose values change from
  step to step named as *slots*;
* a precompute for each reference (:meth:`QpBlock.retarget`);
* its per-step writes: its rows of l and u and its part of q (:meth:`QpBlock.write`), and the values of its slots
  (:meth:`QpBlock.write_matrices`).

:class:`BlockQp` assembles P and A with every entry that can ever be nonzero and computes where each slot's
entries land in the CSC data arrays, so a step hands a solver values only (OSQP's ``update(q=, l=, u=, Px=, Px_idx=,
Ax=, Ax_idx=)``) and the sparsity pattern never changes. Adding a constraint is one class and one entry in the list of
blocks: no offsets are written by hand anywhere.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from agvctl.config import document_fields

__all__ = ["BlockQp", "Pattern", "QpBlock", "VariableBlock", "VariableLayout"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
R = TypeVar("R")
S = TypeVar("S")


@document_fields
@dataclass(frozen=True)
class VariableBlock:
    """A named slice of the QP's variables z."""

    name: str
    """What the variables are (unique in the problem)."""
    size: int
    """How many variables."""


class VariableLayout:
    """Where each variable block starts in z, in the order the blocks were given.

    Parameters
    ----------
    blocks : sequence of VariableBlock
        The variable blocks, first to last.
    """

    def __init__(self, blocks: Sequence[VariableBlock]) -> None:
        self._start: dict[str, int] = {}
        offset = 0
        for block in blocks:
            if block.name in self._start:
                raise ValueError(f"two variable blocks are named {block.name!r}")
            self._start[block.name] = offset
            offset += block.size
        self.n_variables = offset
        """The number of variables."""

    def start(self, name: str) -> int:
        """The index in z of the first variable of the block ``name``.

        Parameters
        ----------
        name : str
            The variable block's name.

        Returns
        -------
        int
            Its first index.
        """
        return self._start[name]


class Pattern:
    """The entries a block contributes to one matrix (A in the block's own rows, P in z's indices, upper triangle),
    in the order added; an entry added with a ``slot`` name varies, and its position in the CSC data array is given
    back to the block (:attr:`BlockQp.a_slots`, :attr:`BlockQp.p_slots`) in that order."""

    def __init__(self) -> None:
        self.rows: list[int] = []
        self.columns: list[int] = []
        self.values: list[float] = []
        self.slots: dict[str, list[int]] = {}

    def add(self, row: int, column: int, value: float, slot: str | None = None) -> None:
        """Add an entry (its value at set-up: a varying entry's placeholder).

        Parameters
        ----------
        row : int
            Its row.
        column : int
            Its column (an index in z).
        value : float
            Its value.
        slot : str or None
            The name of the varying entries it belongs to (None: it never changes).
        """
        if slot is not None:
            self.slots.setdefault(slot, []).append(len(self.rows))
        self.rows.append(row)
        self.columns.append(column)
        self.values.append(value)


class QpBlock(Generic[R, S]):
    """One part of the QP: its variables, rows and matrix entries, its precompute for each reference (of type R) and
    its writes for each step (of type S). A subclass overrides what it has; the defaults have nothing.

    :meth:`bind` gives the block its views of the problem's vectors before the solver is set up: what it writes there
    then is the set-up's data (e.g. a bound that never changes).
    """

    name: str = "block"
    """What the block is, for messages and lookups."""
    variables: tuple[VariableBlock, ...] = ()
    """The variables the block introduces (laid out after those of the blocks before it)."""
    n_rows: int = 0
    """Its number of constraint rows."""
    c_step: str | None = None
    """The block's part of the QP step in C: the template ``step/<c_step>.c.j2`` beside
    :mod:`agvctl.controllers.mpc.c_step`, which renders its state (``part == "state"``) and its writes (``part ==
    "code"``) as :meth:`write` and :meth:`write_matrices` compute them. None: the block has no C of the package's (see
    :attr:`c_template`)."""
    c_template: str | None = None
    """The block's part of the QP step in C as the text of a Jinja template, rendered as a ``step/`` template is (a
    block of your own brings its C this way); None: the template :attr:`c_step` names. A block with neither has no C,
    and neither has a QP that holds it."""
    c_tables_names: tuple[str, ...] = ()
    """The names of the tables :meth:`c_tables` gives, in that order."""

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """Add the block's entries of A, in its own rows 0 … :attr:`n_rows` − 1.

        Parameters
        ----------
        layout : VariableLayout
            Where the variables lie.
        pattern : Pattern
            Where to add them.
        """

    def cost(self, layout: VariableLayout, pattern: Pattern) -> None:
        """Add the block's entries of P (upper triangle: row ≤ column).

        Parameters
        ----------
        layout : VariableLayout
            Where the variables lie.
        pattern : Pattern
            Where to add them.
        """

    def bind(self, qp: BlockQp[R, S], rows: slice) -> None:
        """Keep the views the block writes into: its ``rows`` of ``qp.bounds``, its slots' positions, q.

        Parameters
        ----------
        qp : BlockQp
            The assembled problem.
        rows : slice
            The block's rows.
        """

    def retarget(self, reference: R) -> None:
        """Precompute what the block's writes need for ``reference``.

        Parameters
        ----------
        reference : R
            The reference's data.
        """

    def c_values(self, qp: BlockQp[R, S]) -> dict[str, object]:
        """What the block's C template is rendered with, besides its rows (``first_row``, ``n_rows``): positions,
        sizes, constants of its settings.

        Parameters
        ----------
        qp : BlockQp
            The assembled problem.

        Returns
        -------
        dict
            Names and values for the template.
        """
        del qp
        return {}

    def c_tables(self) -> dict[str, FloatArray]:
        """The block's precompute for the present reference as its C reads it: name → one-dimensional array, the
        names those of :attr:`c_tables_names`.

        Returns
        -------
        dict of str to ndarray
            The tables.
        """
        return {}

    def write(self, step: S) -> None:
        """Write the step's rows of l and u and the block's part of q.

        Parameters
        ----------
        step : S
            The step's data.
        """

    def write_matrices(self, step: S) -> tuple[bool, bool]:
        """Write the step's values of the block's slots into ``qp.a_data`` and ``qp.p_data``.

        Parameters
        ----------
        step : S
            The step's data.

        Returns
        -------
        tuple of bool
            Whether any value of A, and of P, changed since the last step (False: the solver keeps what it has).
        """
        return False, False


def _assemble(
    shape: tuple[int, int], patterns: Sequence[tuple[int, Pattern]]
) -> tuple[sp.csc_matrix, list[dict[str, IntArray]]]:
    """The CSC matrix of the patterns' entries (each pattern's rows offset by its first row), its indices sorted, and
    each pattern's slots as positions in its data array."""
    rows: list[int] = []
    columns: list[int] = []
    values: list[float] = []
    firsts: list[int] = []
    for row0, pattern in patterns:
        firsts.append(len(rows))
        rows.extend(row0 + r for r in pattern.rows)
        columns.extend(pattern.columns)
        values.extend(pattern.values)
    ids = np.arange(1, len(rows) + 1, dtype=np.float64)
    matrix = sp.csc_matrix((ids, (rows, columns)), shape=shape)
    if matrix.nnz != len(rows):
        raise ValueError("two blocks add the same entry of a matrix")
    matrix.sort_indices()
    order = matrix.data.astype(np.int64) - 1  # CSC position p holds entry order[p]
    position = np.empty_like(order)
    position[order] = np.arange(len(order))
    matrix.data = np.asarray(values, dtype=np.float64)[order]
    slots = [
        {name: position[first + np.asarray(entries, dtype=np.int64)] for name, entries in pattern.slots.items()}
        for first, (_, pattern) in zip(firsts, patterns, strict=True)
    ]
    return matrix, slots


def _overrides(block: QpBlock[R, S], method: str) -> bool:
    return getattr(type(block), method) is not getattr(QpBlock, method)


class BlockQp(Generic[R, S]):
    """The QP of ``variables`` and ``blocks``, assembled: the matrices with every entry that can ever be nonzero, the
    vectors, and where each block's rows and slots lie.

    Rows follow the order of the blocks; the variables are ``variables`` followed by each block's own, in the order of
    the blocks. Each block is bound (:meth:`QpBlock.bind`) once the problem is assembled.

    Parameters
    ----------
    variables : sequence of VariableBlock
        The variables no block introduces, first in z.
    blocks : sequence of QpBlock
        The blocks, in row order (a block that tightens another's rows comes after it).
    """

    def __init__(self, variables: Sequence[VariableBlock], blocks: Sequence[QpBlock[R, S]]) -> None:
        self.blocks = tuple(blocks)
        """The blocks, in row order."""
        self.layout = layout = VariableLayout([*variables, *(v for b in self.blocks for v in b.variables)])
        """Where the variables lie."""
        n_z = layout.n_variables
        self.rows: dict[str, slice] = {}
        """Each block's rows, by name."""
        a_patterns: list[tuple[int, Pattern]] = []
        p_patterns: list[tuple[int, Pattern]] = []
        row = 0
        for block in self.blocks:
            if block.name in self.rows:
                raise ValueError(f"two blocks are named {block.name!r}")
            self.rows[block.name] = slice(row, row + block.n_rows)
            a, p = Pattern(), Pattern()
            block.constraints(layout, a)
            block.cost(layout, p)
            if any(not 0 <= r < block.n_rows for r in a.rows):
                raise ValueError(f"block {block.name!r} adds an entry of A outside its {block.n_rows} rows")
            if any(r > c for r, c in zip(p.rows, p.columns, strict=True)):
                raise ValueError(f"block {block.name!r} adds an entry of P below the diagonal")
            a_patterns.append((row, a))
            p_patterns.append((0, p))
            row += block.n_rows
        self.n_rows = row
        """The number of constraint rows."""
        self.A, a_slots = _assemble((row, n_z), a_patterns)
        """The constraint matrix at set-up (varying entries at their placeholders), CSC, indices sorted."""
        self.P, p_slots = _assemble((n_z, n_z), p_patterns)
        """P's upper triangle at set-up, CSC, indices sorted."""
        self.a_data = self.A.data.copy()
        """A's data array as the steps write it."""
        self.p_data = self.P.data.copy()
        """P's data array as the steps write it."""
        self.a_slots = {b.name: s for b, s in zip(self.blocks, a_slots, strict=True)}
        """Each block's slots of A: name → positions in :attr:`a_data`, in the order the block added them."""
        self.p_slots = {b.name: s for b, s in zip(self.blocks, p_slots, strict=True)}
        """Each block's slots of P: name → positions in :attr:`p_data`."""
        self.a_varying = np.unique(np.concatenate([np.zeros(0, np.int64), *(p for s in a_slots for p in s.values())]))
        """Every varying position of A's data, sorted."""
        self.p_varying = np.unique(np.concatenate([np.zeros(0, np.int64), *(p for s in p_slots for p in s.values())]))
        """Every varying position of P's data, sorted."""
        self.q = np.zeros(n_z)
        """The cost's linear term."""
        self.bounds = np.zeros((2, row))
        """The lower and upper bounds as the rows of one array (a block writes both with one copy)."""
        self.lower, self.upper = self.bounds[0], self.bounds[1]
        for block in self.blocks:
            block.bind(self, self.rows[block.name])
        self._writers = [b for b in self.blocks if _overrides(b, "write")]
        self._matrix_writers = [b for b in self.blocks if _overrides(b, "write_matrices")]

    def block(self, name: str) -> QpBlock[R, S]:
        """The block named ``name``.

        Parameters
        ----------
        name : str
            Its name.

        Returns
        -------
        QpBlock
            The block.
        """
        return self.blocks[list(self.rows).index(name)]

    def varying_index(self, matrix: str, positions: IntArray) -> list[int]:
        """Where entries of a matrix's data lie among its varying entries: the order in which a solver takes their
        values (``Ax``/``Px`` of :meth:`matrix_update`).

        Parameters
        ----------
        matrix : {'A', 'P'}
            The matrix.
        positions : ndarray of int
            Positions in its data array (:attr:`a_slots`, :attr:`p_slots`).

        Returns
        -------
        list of int
            Their indices in :attr:`a_varying` (or :attr:`p_varying`).
        """
        varying = self.a_varying if matrix == "A" else self.p_varying
        index = np.searchsorted(varying, positions)
        if not np.array_equal(varying[index], positions):
            raise ValueError(f"positions of {matrix} that are not among its varying entries")
        return [int(i) for i in index]

    def retarget(self, reference: R) -> None:
        """Every block's precompute for ``reference``.

        Parameters
        ----------
        reference : R
            The reference's data.
        """
        for block in self.blocks:
            block.retarget(reference)

    def write(self, step: S) -> None:
        """Every block's writes of l, u and q for ``step``, in row order.

        Parameters
        ----------
        step : S
            The step's data.
        """
        for block in self._writers:
            block.write(step)

    def matrix_update(self, step: S) -> dict[str, IntArray | FloatArray]:
        """Every block's slot values for ``step``, as OSQP ``update`` arguments for the matrices whose values changed.

        Parameters
        ----------
        step : S
            The step's data.

        Returns
        -------
        dict
            ``Px``/``Px_idx`` and ``Ax``/``Ax_idx`` (every varying entry of the matrix) for each matrix a block changed,
            only those: a matrix handed over again is rescaled by OSQP, which can change its last digits.
        """
        a_changed = p_changed = False
        for block in self._matrix_writers:
            a, p = block.write_matrices(step)
            a_changed |= a
            p_changed |= p
        update: dict[str, IntArray | FloatArray] = {}
        if p_changed:
            update.update(Px=self.p_data[self.p_varying], Px_idx=self.p_varying)
        if a_changed:
            update.update(Ax=self.a_data[self.a_varying], Ax_idx=self.a_varying)
        return update
