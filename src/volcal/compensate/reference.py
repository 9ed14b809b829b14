"""On which line a pitch table is valid, and what an Abbe offset does to it.

A pitch table holds the positioning error of an axis (EXX, EYY, EZZ) on the axis'
**reference line**: the tool point when the axes read after it in the chain (workpiece ->
tool) are at 0 and the tool offset is 0 (``docs/conventions.md``). On any other line the
axis' tilts act on the lever arm ``L`` (tool offset plus the positions of the axes after
it) and the positioning error seen there is, to first order (Soons 2005, eq. 1),

* X: ``EXX + EBX * Lz - ECX * Ly``,
* Y: ``EYY + ECY * Lx - EAY * Lz``,
* Z: ``EZZ + EAZ * Ly - EBZ * Lx``

(``urad * mm * 1e-3 = um``). A per-axis pitch table cannot correct the tilt terms: on a
line far from the reference line it can leave a larger error than before. The notes of
every per-axis table set state this (:func:`reference_line_notes`).

References
----------
ISO 230-1:2012, 3.4 and annex A; Soons (seed 004), eq. 1; docs/conventions.md ("Lever
arms of the Abbe lines").
"""

from __future__ import annotations

import numpy as np

from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

__all__ = ["ABBE_TERMS", "abbe_formula", "reference_line", "reference_line_notes"]

ABBE_TERMS: dict[int, tuple[tuple[int, int, float], ...]] = {
    0: ((4, 2, +1.0), (5, 1, -1.0)),  # X: + EBX * Lz - ECX * Ly
    1: ((5, 0, +1.0), (3, 2, -1.0)),  # Y: + ECY * Lx - EAY * Lz
    2: ((3, 1, +1.0), (4, 0, -1.0)),  # Z: + EAZ * Ly - EBZ * Lx
}
"""Axis -> (column of its error table (3 = EA, 4 = EB, 5 = EC), lever component, sign)."""


def reference_line(errors: MachineErrors, axis: int) -> str:
    """Plain words: where the reference line of ``axis`` lies.

    Parameters
    ----------
    errors : MachineErrors
        The model (its chain decides which axes move the line).
    axis : int
        0, 1, 2.

    Returns
    -------
    str
        E.g. ``"y = 0 mm, z = 0 mm, tool offset 0 (x: any position)"``.
    """
    after = errors.chain_obj.downstream(axis)
    before = [j for j in range(3) if j != axis and j not in after]
    parts = [f"{AXES[j].lower()} = 0 mm" for j in after] + ["tool offset 0"]
    text = ", ".join(parts)
    if before:
        text += (f" ({', '.join(AXES[j].lower() for j in before)}: any position, "
                 "it does not move the line)")
    return text


def abbe_formula(axis: int) -> str:
    """The positioning error of ``axis`` on a line at lever ``L`` [um], as text.

    Parameters
    ----------
    axis : int
        0, 1, 2.

    Returns
    -------
    str
        E.g. ``"EYY + ECY*Lx - EAY*Lz"`` (tilts [urad], levers [mm]).
    """
    a = AXES[axis]
    terms = " ".join(("+ " if s > 0 else "- ") + f"E{'ABC'[c - 3]}{a}*L{AXES[lv].lower()}"
                     for c, lv, s in ABBE_TERMS[axis])
    return f"E{a}{a} {terms}"


def reference_line_notes(errors: MachineErrors, axes: tuple[int, ...] = (0, 1, 2)
                         ) -> list[str]:
    """One note per pitch table: its reference line and its Abbe terms with the model's sizes.

    Parameters
    ----------
    errors : MachineErrors
        The model the tables are written from.
    axes : tuple of int
        Axes with a pitch table.

    Returns
    -------
    list of str
        Plain-text lines for a table's notes or comments.
    """
    out = []
    for k in axes:
        a = AXES[k]
        tilts = np.abs(np.asarray(errors.values[k], dtype=float)[:, 3:6]).max(axis=0)
        sizes = ", ".join(f"E{'ABC'[c - 3]}{a} up to {tilts[c - 3]:.1f} urad"
                          for c, _, _ in ABBE_TERMS[k])
        worst = max(tilts[c - 3] for c, _, _ in ABBE_TERMS[k]) * 100.0 * 1e-3
        out.append(
            f"{a} pitch table (E{a}{a}): valid on the reference line of {a}: "
            f"{reference_line(errors, k)}, model coordinates. On a line at lever L "
            f"(tool offset + positions of the axes after {a} in chain "
            f"{errors.chain_obj.code}) the positioning error of {a} is "
            f"{abbe_formula(k)} [urad x mm x 1e-3 = um]; the table does not correct the "
            f"tilt (Abbe) terms. Model: {sizes}, i.e. up to {worst:.2f} um per 100 mm of "
            "offset.")
    return out
