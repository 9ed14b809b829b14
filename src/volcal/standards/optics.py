"""Each direct optic's own evaluation (ISO 230-1:2012), without a model.

* straightness lines: the straightness deviation about the end-point and the
  least-squares reference lines (:func:`volcal.standards.straightness.straightness`);
* angular lines: the angular deviation, the range of the readings over the travel
  (ISO 230-1:2012, 3.4.4 and 10.3);
* optical-square pairs (a reference group's first line and a line across it, each read
  along the other's axis): the squareness, the angle between the ``+`` directions of the
  two axes minus 90 degrees, from the reference lines' slopes ``s1 = dv/du``,
  ``s2 = du/dv`` (:func:`volcal.standards.straightness.squareness_from_slopes`) corrected
  by the square's deviation from its certificate: ``-(s1 + s2) + square_deviation_urad``
  (the reference group's rotation cancels in the sum). Given for the least-squares lines
  (ISO 230-1) and the end-point lines; the identified EC0Y, EB0Z, EA0Z use the end-point
  gauge of ``volcal identify`` (``docs/identification.md``), so they agree with the
  end-point figure, and differ from the least-squares one when a straightness is curved.
  volcal's names: EC0Y = S_xy, EB0Z = -S_xz, EA0Z = S_yz (``volcal.model.names``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.session.format import Measurement, Session
from volcal.standards.straightness import squareness_from_slopes, straightness

__all__ = ["evaluate_optics"]

_SQ_NAME = {frozenset("xy"): ("EC0Y", 1.0), frozenset("xz"): ("EB0Z", -1.0),
            frozenset("yz"): ("EA0Z", 1.0)}


def _axis(m: Measurement) -> int:
    """The axis a direct optic's line runs along (Measurement.axis: never None for it)."""
    k = m.axis
    assert k is not None
    return k


def _line(m: Measurement) -> dict[str, Any]:
    k = _axis(m)
    s = m.positions[:, k]
    d = np.asarray(m.deviation, dtype=float)
    out: dict[str, Any] = {"axis": "xyz"[k], "error_direction": m.meta["error_direction"],
                           "length_mm": float(np.ptp(s))}
    for ref in ("end_point", "least_squares"):
        r = straightness(s, d, ref)
        out[ref] = {"straightness_um": r.straightness_um, "slope_urad": r.slope_urad}
    if m.meta.get("slope_removed"):
        out["note"] = "slope removed by the instrument: slopes are not the machine's"
    return out


def _angle(m: Measurement) -> dict[str, Any]:
    d = np.asarray(m.deviation, dtype=float)
    return {"axis": "xyz"[_axis(m)], "rotation": m.meta["rotation"], "target": m.target,
            "angular_deviation_urad": float(np.ptp(d)),
            "min_urad": float(d.min()), "max_urad": float(d.max())}


def _squareness(first: Measurement, other: Measurement, lines: dict[str, dict],
                ref: dict[str, Any]) -> dict[str, Any] | None:
    u, v = first.meta["axis"], other.meta["axis"]
    if first.meta["error_direction"] != v or other.meta["error_direction"] != u:
        return None  # not read in the plane of the pair
    name, sign = _SQ_NAME[frozenset(u + v)]
    delta = float(ref.get("square_deviation_urad", 0.0))
    out: dict[str, Any] = {"lines": [first.id, other.id], "axes": u + v,
                           "square_deviation_urad": delta, "name": name}
    for r in ("least_squares", "end_point"):
        ang = squareness_from_slopes(lines[first.id][r]["slope_urad"],
                                     lines[other.id][r]["slope_urad"]) + delta
        # the angle of the pair (u, v) minus 90 degrees equals that of (v, u)
        out[r] = {"angle_minus_90_urad": ang, name: sign * ang}
    out["reference_note"] = (f"{name} from the least-squares lines (ISO 230-1) and from the "
                             "end-point lines (the gauge of the identified model)")
    return out


def evaluate_optics(session: Session) -> dict[str, Any]:
    """Evaluate every straightness, angular and optical-square measurement of a session.

    Parameters
    ----------
    session : Session
        A measured session.

    Returns
    -------
    dict
        ``straightness`` (id -> end-point and least-squares straightness [um] and slope
        [urad]), ``angular`` (id -> angular deviation [urad]), ``squareness`` (list of
        optical-square pairs: angle minus 90 degrees [urad] and the volcal name's value
        for each reference).
    """
    lines = {m.id: _line(m) for m in session.measurements
             if m.kind == "straightness" and m.deviation is not None}
    angles = {m.id: _angle(m) for m in session.measurements
              if m.kind == "angular" and m.deviation is not None}
    groups: dict[str, list[Measurement]] = {}
    for m in session.measurements:
        if m.kind == "straightness" and m.meta.get("reference") and m.id in lines:
            groups.setdefault(str(m.meta["reference"]), []).append(m)
    sq = []
    for name, ms in groups.items():
        first = ms[0]
        for other in ms[1:]:
            if other.meta["axis"] != first.meta["axis"] and not first.meta.get("slope_removed"):
                r = _squareness(first, other, lines, session.references.get(name, {}))
                if r is not None:
                    sq.append({"reference": name, **r})
    return {"straightness": lines, "angular": angles, "squareness": sq}
