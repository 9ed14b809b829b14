"""ISO 230-2 accuracy A of every rotary test before and after the rotary tables written.

As :mod:`volcal.compensate.linecheck` does for the linear lines: the readings of each
rotary test of the session are evaluated to ISO 230-2 twice, as measured (before) and
minus the error the written table removes at each commanded angle and approach direction
(after), the table read back from its file(s) and applied as the control does
(:func:`volcal.compensate.rotary.rotary_removed_urad`). ``u`` is repeatability-based: the
largest unidirectional standard uncertainty ``s_i`` of the test's targets. A test whose A
grows by more than ``u`` is flagged. Units: urad.

ISO 230-2 for rotary axes (:func:`volcal.standards.iso230_2_rotary.evaluate_rotary`): on a
full-circle axis 0 and 360 deg stay two targets (ISO 230-2 counts each target approached),
the same physical position for the table.

References
----------
ISO 230-2:2014, 3.3 (A, s_i); docs/compensation.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError

__all__ = ["RotaryCheck", "check_rotary"]


@dataclass(frozen=True)
class RotaryCheck:
    """One rotary test before and after its table.

    Attributes
    ----------
    id : str
        Measurement id.
    axis : str
        ``'A'``, ``'B'`` or ``'C'``.
    A_before_urad, A_after_urad : float
        ISO 230-2 accuracy A as measured and with the table [urad].
    u_urad : float
        Repeatability-based uncertainty (largest ``s_i``) [urad].
    modulo : bool
        A full-circle axis: 0 and 360 deg are one position, the table is periodic.
    closure_urad : dict or None
        Full circle: the difference of the means at 360 and 0 deg per direction
        (``'up'``, ``'down'``) [urad] (what the table averages into one value).
    """

    id: str
    axis: str
    A_before_urad: float
    A_after_urad: float
    u_urad: float
    modulo: bool = True
    closure_urad: dict[str, float] | None = None

    @property
    def worse(self) -> bool:
        """A grows by more than ``u``."""
        return self.A_after_urad - self.A_before_urad > self.u_urad


def check_rotary(session: Any, folder: str | Path, fmt: str, entries: list[dict[str, Any]],
                 edition: str = "2014") -> tuple[list[RotaryCheck], list[str]]:
    """A before and after of each rotary test that got a table.

    Parameters
    ----------
    session : Session
        The measured session.
    folder : str or Path
        The compensation folder.
    fmt : str
        Its format.
    entries : list of dict
        The rotary entries of its manifest.
    edition : str
        ISO 230-2 edition.

    Returns
    -------
    checks : list of RotaryCheck
    skipped : list of str
        ``"id: why"`` for rotary tests not evaluated.
    """
    from volcal.compensate.rotary import rotary_removed_urad
    from volcal.standards.iso230_2_rotary import evaluate_rotary

    by_id = {str(e["id"]): e for e in entries}
    checks: list[RotaryCheck] = []
    skipped: list[str] = []
    for m in session.measurements:
        if m.kind != "rotary" or m.deviation is None or m.id not in by_id:
            continue
        if "run" not in m.columns or "direction" not in m.columns:
            skipped.append(f"{m.id}: no run/direction columns")
            continue
        t = np.asarray(m.columns["target_deg"], dtype=float)
        d = np.asarray(m.columns["direction"]).astype(str)
        dev = np.asarray(m.deviation, dtype=float)
        run = np.asarray(m.columns["run"])
        ok = np.isfinite(dev)
        try:
            removed = rotary_removed_urad(folder, fmt, by_id[m.id], t[ok], d[ok])
            axis, modulo = str(m.meta.get("axis", "?")), bool(m.meta.get("modulo", True))
            full = evaluate_rotary(t[ok], run[ok], d[ok], dev[ok], edition, axis=axis,
                                   modulo=modulo, allow_incomplete=True)
            before = full.iso
            after = evaluate_rotary(t[ok], run[ok], d[ok], dev[ok] - removed, edition,
                                    axis=axis, modulo=modulo, allow_incomplete=True).iso
        except VolcalInputError as exc:
            skipped.append(f"{m.id}: {exc.message}")
            continue
        s = np.concatenate([before.targets.s_up, before.targets.s_down])
        s = s[np.isfinite(s)]
        u = float(s.max()) if s.size else 0.0
        checks.append(RotaryCheck(m.id, str(m.meta.get("axis", "?")).upper(), float(before.A),
                                  float(after.A), u if math.isfinite(u) else 0.0, modulo,
                                  dict(full.closure_urad) if full.closure_urad else None))
    return checks, skipped
