"""Report section of the probe_sphere tests: the rotary axes' location errors with U."""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.report.document import Section, Table, fmt

__all__ = ["location_section"]


def _blocks(ms: list[Any]) -> list[Any]:
    """The tests as the estimator's blocks.

    The kind's own helper, rebuilt here: the report sits below the kinds.
    """
    from volcal.measure.spheres import SphereReadings
    from volcal.session.probe_sphere import _angles, _keys

    out = []
    for m in ms:
        k = _keys(m)
        out.append(SphereReadings(m.id, "probe", _angles(m), np.asarray(m.positions, float),
                                  k["sphere"], k["sphere_mm"],
                                  np.asarray(m.tool_offset, float), None, k["noise_um"]))
    return out


def location_section(inp: Any) -> Section | None:
    """The location errors the session's probe_sphere tests determine, with U (k = 2).

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results; the identified linear model (``inp.result``), when there is
        one, is taken as the linear axes' errors.

    Returns
    -------
    Section or None
        None without a measured probe_sphere test.
    """
    from volcal.identify.location import identify_location
    from volcal.session.probe_sphere import five_axis_machine

    ms = [m for m in inp.session.measurements
          if m.kind == "probe_sphere" and m.deviation is not None]
    if not ms:
        return None
    sec = Section("location", "Rotary axes: location errors (probe on a sphere)")
    chains = list(dict.fromkeys(m.meta["chain"] for m in ms))
    result = getattr(inp, "result", None)
    linear = getattr(result, "errors", None)
    sec.paragraphs.append(
        "The centre of a calibration sphere probed at a set of rotary poses, as the control "
        "reports it in machine coordinates, identifies where the rotary axes' lines are "
        "(ISO 230-1 location errors: positions EX0C... [µm] of the lines, their orientations "
        "EA0C... and the zeros of the angles [µrad]); signs and references in "
        "docs/fiveaxis.md. Errors the poses cannot separate are held at zero; the ones "
        "determined then stand for the combinations named below. The linear axes' errors "
        + ("are those identified above." if linear is not None else "are taken as perfect."))
    for chain in chains:
        group = [m for m in ms if m.meta["chain"] == chain]
        nominal = five_axis_machine(group[0], linear)
        res = identify_location(nominal, _blocks(group))
        rows = []
        for r in res.to_rows():
            u = float(r["u"])  # type: ignore[arg-type]
            rows.append([str(r["name"]), str(r["meaning"]),
                         "-" if np.isnan(u) else fmt(float(r["value"]), 2),  # type: ignore[arg-type]
                         "-" if np.isnan(u) else fmt(2.0 * u, 2),
                         "µm" if r["unit"] == "um" else "µrad", str(r["status"])])
        sec.tables.append(Table(
            ["error", "meaning", "value", "U (k = 2)", "unit", "status"], rows,
            f"Location errors of the rotary axes, chain {chain} "
            f"({', '.join(m.id for m in group)})",
            f"Scatter of the sphere centre: RMS {fmt(res.rms_before_um, 2)} µm with the "
            f"configured kinematics, {fmt(res.rms_after_um, 2)} µm with the identified "
            f"location errors (chi-square {fmt(res.chi2, 1)} on {res.dof} degrees of "
            "freedom)."))
        sec.paragraphs.extend(res.identifiability.messages)
    return sec
