"""Base of the kinds evaluated on their own, outside the linear identification.

A rotary axis' angular positioning (:mod:`volcal.kinds.rotary`), sphere centres probed at
rotary poses (:mod:`volcal.kinds.probe_sphere`) and the R-test (:mod:`volcal.kinds.r_test`)
are evaluated per axis or by the location fit (``docs/fiveaxis.md``); their readings do
not enter ``volcal identify`` (:attr:`volcal.session.kinds.Kind.in_design` False). Their
Jacobian rows on the linear axes' parameters are one zero block with the reading offset,
written here once.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from volcal.session.kinds import Kind, RowBlock

__all__ = ["OutsideDesignKind"]


class OutsideDesignKind(Kind):
    """A kind whose readings stay out of the linear identification (``in_design`` False)."""

    in_design: ClassVar[bool] = False
    along_beam: ClassVar[bool] = False

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        """No rows on the linear axes' parameters: a zero block with the reading offset.

        The estimator leaves these measurements out (:attr:`in_design`); this block says
        so in numbers.

        Parameters
        ----------
        chain_order : sequence of int
            ``Chain.order``.
        nodes : list of 3 arrays
            Node positions per axis [mm].
        m : Measurement
            The measurement.
        drift : bool
            Unused.
        tilts : bool
            Unused.

        Returns
        -------
        RowBlock
            ``m.n`` zero rows over the ``6 n + 3`` parameters, the readings (zeros when
            not measured) and one offset column ``<id>:offset``.
        """
        y = np.zeros(m.n) if m.deviation is None else np.asarray(m.deviation, dtype=float)
        import scipy.sparse as sp  # here: reading a session needs no scipy

        from volcal.model.parameters import ParameterLayout

        P = ParameterLayout.of_nodes(nodes).size  # 6 per node and the 3 squareness
        return RowBlock(sp.csr_matrix((m.n, P)), y, np.ones((m.n, 1)), [f"{m.id}:offset"])
