"""ISO 230-2 accuracy A of every measured linear line before and after written tables.

``volcal compensate --session S`` reads the tables it has just written back from their
files (:mod:`volcal.compensate.readback`) and, for every linear test of the session with
runs and approach directions, evaluates ISO 230-2 twice: the readings as measured
(before) and the readings minus what the tables remove at each commanded position,
projected on the beam (after: the controller's sign, interpolation rule and, for
bidirectional tables, the table of the approach direction). A line whose ``A`` grows by
more than its uncertainty ``u`` is flagged: typically a line at another Abbe offset than
the reference line the pitch table was written for (:mod:`volcal.compensate.reference`).

``u`` is the line's own: taken from an uncertainty budget when one is given (per
measurement id), otherwise repeatability-based, the largest estimator of the
unidirectional standard uncertainty of positioning ``s_i`` of the line's targets
(ISO 230-2:2014, 3.3), and the message says which.

References
----------
ISO 230-2:2014, 3.3 (A, s_i); docs/compensation.md ("What the tables do to each
measured line").
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError
from volcal.model.names import AXES

__all__ = ["LineCheck", "check_lines", "volumetric_before_after"]

REPEATABILITY_U = ("repeatability-based: the largest unidirectional standard uncertainty "
                   "s_i of the line's targets, ISO 230-2; no uncertainty budget")
"""How the message names the fallback uncertainty."""


@dataclass(frozen=True)
class LineCheck:
    """One linear line before and after the tables.

    Attributes
    ----------
    id : str
        Measurement id.
    axis : str
        ``'X'``, ``'Y'`` or ``'Z'``.
    line : str
        Where the line lies: the other axes' positions and the tool offset [mm].
    A_before_um, A_after_um : float
        ISO 230-2 accuracy A of the readings as measured and with the tables [um].
    u_um : float
        The line's uncertainty [um].
    u_source : str
        Where ``u`` comes from (a budget, or :data:`REPEATABILITY_U`).
    """

    id: str
    axis: str
    line: str
    A_before_um: float
    A_after_um: float
    u_um: float
    u_source: str

    @property
    def short(self) -> str:
        """The line in a few characters: ``x=0 z=600 t=0,0,0`` [mm]."""
        parts = [p.replace(" mm", "").replace(" = ", "=") for p in self.line.split(", ")[:2]]
        t = self.line.split("tool offset (")[1].split(")")[0].replace(" ", "")
        return " ".join(parts) + f" t={t}"

    @property
    def worse(self) -> bool:
        """A grows by more than the line's uncertainty."""
        return self.A_after_um - self.A_before_um > self.u_um

    def warning(self) -> str:
        """The message printed for a line the tables make worse."""
        return (f"{self.axis} line {self.id} ({self.line}): ISO 230-2 A grows from "
                f"{self.A_before_um:.2f} µm to {self.A_after_um:.2f} µm with these tables "
                f"(+{self.A_after_um - self.A_before_um:.2f} µm), more than the line's "
                f"uncertainty u = {self.u_um:.2f} µm ({self.u_source}); the pitch table is "
                f"valid on {self.axis}'s reference line, this line is at another Abbe offset "
                "(see the tables' notes)")


def _where(m: Any) -> str:
    k = m.axis
    p0 = m.positions[0]
    other = ", ".join(f"{AXES[j].lower()} = {p0[j]:g} mm" for j in range(3) if j != k)
    t = ", ".join(f"{v:g}" for v in m.tool_offset)
    return f"{other}, tool offset ({t}) mm"


def check_lines(session: Any, tables: Any, edition: str = "2014",
                budget_u_um: dict[str, float] | None = None) -> tuple[list[LineCheck],
                                                                      list[str]]:
    """ISO 230-2 A of every measured linear line, before and after the tables.

    Parameters
    ----------
    session : Session
        A measured session.
    tables : WrittenTables
        The tables as written (:func:`volcal.compensate.readback.read_written_tables`).
    edition : str
        ISO 230-2 edition.
    budget_u_um : dict of str to float, optional
        Standard uncertainty of A per measurement id from an uncertainty budget [um];
        lines not in it use the repeatability-based ``u``.

    Returns
    -------
    checks : list of LineCheck
        One per linear test with runs and directions.
    skipped : list of str
        ``"id: why"`` for the linear tests that could not be evaluated.
    """
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import from_measurement

    checks: list[LineCheck] = []
    skipped: list[str] = []
    for m in session.measurements:
        if m.kind != "linear" or m.deviation is None:
            continue
        if m.axis is None or "run" not in m.columns or "direction" not in m.columns:
            skipped.append(f"{m.id}: no axis or no run/direction columns")
            continue
        try:
            d = from_measurement(m, session.path)
            # incomplete runs (missed readings) are evaluated where the reader allows it
            kw = d.evaluate_kwargs() if hasattr(d, "evaluate_kwargs") else {}
            before = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, edition, **kw)
            m2 = dataclasses.replace(m, deviation=tables.deviation_after(m))
            d2 = from_measurement(m2, session.path)
            after = evaluate(d2.targets_mm, d2.run, d2.direction, d2.deviation_um, edition,
                             **kw)
        except VolcalInputError as exc:
            skipped.append(f"{m.id}: {exc.message}")
            continue
        if budget_u_um is not None and m.id in budget_u_um:
            u, src = float(budget_u_um[m.id]), "from the uncertainty budget"
        else:
            s = np.concatenate([before.targets.s_up, before.targets.s_down])
            s = s[np.isfinite(s)]
            u, src = (float(s.max()) if s.size else 0.0), REPEATABILITY_U
        if not math.isfinite(u):
            u = 0.0
        checks.append(LineCheck(m.id, AXES[m.axis], _where(m), float(before.A),
                                float(after.A), u, src))
    return checks, skipped


def volumetric_before_after(errors: Any, tables: Any, n: int = 11) -> tuple[float, float]:
    """Largest length of the modelled volumetric error before and after the tables [um].

    Parameters
    ----------
    errors : MachineErrors
        The model the tables were written from.
    tables : WrittenTables
        The tables as written.
    n : int
        Grid points per axis of the work zone (the model's travel).

    Returns
    -------
    before, after : float
        ``max |e|`` and ``max |e - correction|`` over the ``n**3`` points [um].
    """
    from volcal.model.kinematics import volumetric_error
    from volcal.standards.volumetric import work_zone_grid

    q = work_zone_grid(errors.travel, n)
    e = volumetric_error(errors, q)
    return (float(np.linalg.norm(e, axis=1).max()),
            float(np.linalg.norm(e - tables.correction(q), axis=1).max()))
