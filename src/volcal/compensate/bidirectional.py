"""Reversal values for bidirectional tables from the ISO 230-2 linear tests of a session.

For each axis the first linear measurement with ``run`` and ``direction`` columns is
evaluated (ISO 230-2: mean positional deviation per target and approach direction);
the reversal ``r(p) = mean_down(p) - mean_up(p)`` [um] is interpolated linearly
between targets (end values held). The model's positioning error is taken as the
bidirectional mean, so formats with two directions write ``model - r/2`` for the
positive (forward) and ``model + r/2`` for the negative (reverse) direction.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from volcal.errors import VolcalInputError


def reversal_from_session(session: str | Path
                          ) -> tuple[Callable[[np.ndarray], np.ndarray] | None, ...]:
    """Per-axis reversal functions from a session's ISO 230-2 linear runs.

    Parameters
    ----------
    session : str or Path
        Session folder.

    Returns
    -------
    tuple of 3 (callable or None)
        X, Y, Z: ``f(positions [mm]) -> mean_down - mean_up [um]``; None for an axis
        without a bidirectional linear test.

    Raises
    ------
    VolcalInputError
        No axis of the session has a bidirectional linear test.
    """
    from volcal.session.format import read_session
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import from_measurement

    s = read_session(session)
    out: list = [None, None, None]
    for m in s.measurements:
        if m.kind != "linear" or "run" not in m.columns or "direction" not in m.columns:
            continue
        d = from_measurement(m, s.path)
        k = "XYZ".index(d.axis) if d.axis in ("X", "Y", "Z") else None
        if k is None or out[k] is not None:
            continue
        t = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, file=d.file,
                     rows=d.rows).targets
        x = np.asarray(t.target_mm, dtype=float)
        r = np.asarray(t.mean_down, dtype=float) - np.asarray(t.mean_up, dtype=float)
        if not np.all(np.isfinite(r)):
            continue
        order = np.argsort(x)
        out[k] = (lambda xs, rs: (lambda p: np.interp(p, xs, rs)))(x[order], r[order])
    if all(f is None for f in out):
        raise VolcalInputError("no linear measurement with runs in both directions", session)
    return tuple(out)
