"""Report section for multilateration (tracking interferometer) measurements."""

from __future__ import annotations

from functools import partial

import numpy as np

from volcal.report.document import FigureItem, Section, Table, fmt

__all__ = ["multilateration_section"]


def _fit(result):
    fit = getattr(result, "fit", None)
    if fit is None and isinstance(result, dict):
        fit = result.get("fit")
    return (fit or {}).get("multilateration") if isinstance(fit or {}, dict) else None


def multilateration_section(inp) -> Section | None:
    """Layout picture, residuals per station and fitted stations with uncertainties.

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results; the fitted stations come from ``result.fit['multilateration']``.

    Returns
    -------
    Section or None
        None when the session has no multilateration measurement.
    """
    from volcal.measure.multilateration import station_key, station_of
    from volcal.plot.multilateration import multilateration_layout_plot

    ms = [m for m in inp.session.measurements if m.kind == "multilateration"]
    if not ms:
        return None
    sec = Section("multilateration", "Multilateration (tracking interferometer)")
    keys = list(dict.fromkeys(station_key(m) for m in ms))
    label = {k: f"S{i + 1}" for i, k in enumerate(keys)}
    nominal = np.array([station_of(next(m for m in ms if station_key(m) == k)) for k in keys])
    offsets = sorted({tuple(float(v) for v in m.tool_offset) for m in ms})
    sec.paragraphs.append(
        f"{len(ms)} measurements from {len(keys)} tracker stations with {len(offsets)} tool "
        f"offset(s) ({'; '.join(', '.join(f'{v:g}' for v in o) for o in offsets)} mm), "
        f"{sum(m.n for m in ms)} length readings. The stations and the initial distances are "
        "fitted with the machine errors (Schwenke et al., CIRP Annals 54/1, 2005).")
    ml = _fit(inp.result)
    fitted = None
    if ml:
        by = {r["station"]: r for r in ml.get("stations", [])}
        rows = []
        for k in keys:
            r = by.get(k)
            if r is None:
                continue
            shift = np.subtract(r["fitted_mm"], r["nominal_mm"])
            rows.append([label[k], ", ".join(f"{v:.3f}" for v in r["nominal_mm"]),
                         ", ".join(f"{v:.4f}" for v in r["fitted_mm"]),
                         ", ".join(fmt(v, 2) for v in r["u_um"]),
                         fmt(float(np.linalg.norm(shift)), 3)])
        if rows:
            fitted = np.array([by[k]["fitted_mm"] for k in keys if k in by])
            sec.tables.append(Table(["station", "set up x, y, z [mm]", "fitted x, y, z [mm]",
                                     "u(x, y, z) [um]", "shift [mm]"], rows,
                                    "Tracker stations"))
        if not ml.get("converged", True):
            sec.warnings.append("The station positions did not converge: check station_mm.")
    res = getattr(inp.result, "residuals", None) if inp.result is not None else None
    if res:
        rows = []
        for k in keys:
            r = np.concatenate([np.asarray(res[m.id]) for m in ms
                                if station_key(m) == k and m.id in res] or [np.zeros(0)])
            if r.size:
                rows.append([label[k], str(r.size), fmt(float(np.sqrt(np.mean(r**2))), 3),
                             fmt(float(np.abs(r).max()), 3)])
        if rows:
            sec.tables.append(Table(["station", "readings", "RMS residual [um]",
                                     "max |residual| [um]"], rows, "Residuals per station"))
    sec.figures.append(FigureItem(
        partial(multilateration_layout_plot, ms[0].positions + ms[0].tool_offset, nominal,
                fitted, [label[k] for k in keys]),
        "Grid path of the first measurement (nominal tool points) and the tracker stations.",
        "multilateration-layout"))
    return sec
