"""``volcal history fleet``: one HTML page with every machine of the history.

Per machine: identity, last calibration (the newest date of measurement, not the
newest record; date, id), the largest volumetric error
E_VXYZ with its U, a small trend of E_VXYZ over its calibrations with its U band (inline
SVG), the next
due date (overdue in red).
"""

from __future__ import annotations

import datetime as _dt
import html
from pathlib import Path
from typing import Any


def _sparkline(values: list[float], width: int = 120, height: int = 28,
               us: list[float | None] | None = None) -> str:
    """Inline SVG of a trend; with ``us`` (U of each value, None where none) its U band."""
    if not values:
        return ""
    us = us if us is not None else [None] * len(values)
    lo = min(v - (u or 0.0) for v, u in zip(values, us, strict=True))
    hi = max(v + (u or 0.0) for v, u in zip(values, us, strict=True))
    span = hi - lo or 1.0
    n = len(values)

    def xy(i: int, v: float) -> tuple[float, float]:
        return (4 + (width - 8) * (i / (n - 1) if n > 1 else 0.5),
                height - 4 - (height - 8) * (v - lo) / span)

    pts = [xy(i, v) for i, v in enumerate(values)]
    path = " ".join(f"{x:.1f},{y:.1f}" for x, y in pts)
    dots = "".join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2"/>' for x, y in pts)
    with_u = [(i, v, u) for i, (v, u) in enumerate(zip(values, us, strict=True))
              if u is not None]
    band = ""
    if with_u:
        edge = [xy(i, v + u) for i, v, u in with_u] + [xy(i, v - u) for i, v, u in
                                                       reversed(with_u)]
        if len(with_u) == 1:  # one calibration with U: its bar
            (x0, y0), (_, y1) = edge
            band = (f'<line x1="{x0:.1f}" y1="{y0:.1f}" x2="{x0:.1f}" y2="{y1:.1f}" '
                    'stroke="#9bd" stroke-width="3"/>')
        else:
            band = ('<polygon fill="#cde" stroke="none" points="'
                    + " ".join(f"{x:.1f},{y:.1f}" for x, y in edge) + '"/>')
    return (f'<svg width="{width}" height="{height}" role="img" '
            f'aria-label="E_VXYZ trend with U">{band}<polyline fill="none" stroke="#246" '
            f'points="{path}"/>{dots}</svg>')


def fleet_html(history: Any, today: _dt.date | None = None, machine: str | None = None
               ) -> str:
    """The page's HTML text.

    Parameters
    ----------
    history : History
        The store.
    today : date, optional
        Reference date of the due column (default today).
    machine : str, optional
        Only this machine (record id or name): only its records are read.
    """
    from volcal.history.api import by_date
    from volcal.history.due import due_rows as _due_rows
    from volcal.history.due import machine_records

    today = today or _dt.date.today()
    with history.store.reading():  # one connection (and snapshot) for every read
        machines, others = machine_records(history, machine)  # each record read once
        mine: dict[str | None, list[Any]] = {}
        for r in others:
            if r.kind == "calibration" and r.superseded_by is None:
                mine.setdefault(r.machine_id, []).append(r)
        due_rows = _due_rows(history, today, machines, others)
    rows = []
    for mach in machines:
        # by date of measurement: a back-filled older record is not the last one
        cals = by_date(mine.get(mach.id, []))
        ident = mach.payload.get("machine", {})
        who = " ".join(str(ident[k]) for k in ("make", "model") if ident.get(k))
        serial = ident.get("serial", "")
        stated = [r.results.get("V.E_VXYZ", {}) for r in cals]
        ev = [v["value"] for v in stated if v.get("value") is not None]
        ev_u = [v.get("U") for v in stated if v.get("value") is not None]
        last = cals[-1] if cals else None
        evx = last.results.get("V.E_VXYZ") if last else None
        nxt = min((d["next"] for d in due_rows if d["machine_id"] == mach.id), default="")
        overdue = bool(nxt) and nxt < today.isoformat()
        ev_text = "-"
        if evx and evx["value"] is not None:
            ev_text = f"{evx['value']:.2f}" + ("" if evx["U"] is None else f" ± {evx['U']:.2f}")
        rows.append(
            "<tr>"
            f"<td>{html.escape(mach.machine_name)}</td><td>{html.escape(who)}</td>"
            f"<td>{html.escape(str(serial))}</td>"
            f"<td>{html.escape(last.date[:10] if last and last.date else '-')}"
            f"{' (' + html.escape(last.id) + ')' if last else ''}</td>"
            f"<td>{ev_text}</td>"
            f"<td>{_sparkline(ev, us=ev_u)}</td>"
            f"<td class=\"{'overdue' if overdue else ''}\">{html.escape(nxt)}"
            f"{' overdue' if overdue else ''}</td></tr>")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>volcal fleet</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #bbb;padding:4px 8px;text-align:left}}.overdue{{color:#b00;
font-weight:bold}}</style></head><body>
<h1>Machines of the calibration history</h1>
<p>{len(rows)} machines; {html.escape(history.store.where)}; {today.isoformat()}.
E<sub>VXYZ</sub>: largest volumetric error of the identified model over the work zone
[µm] (ISO 230-1), with U (k = 2) where stored.</p>
<table><thead><tr><th>machine</th><th>make, model</th><th>serial</th>
<th>last calibration</th><th>E<sub>VXYZ</sub> [µm]</th><th>trend of E<sub>VXYZ</sub></th>
<th>next due</th></tr></thead><tbody>
{chr(10).join(rows)}
</tbody></table></body></html>
"""


def write_fleet(history: Any, path: str | Path, machine: str | None = None) -> Path:
    """Write the fleet page atomically.

    Parameters
    ----------
    history : History
        The store.
    path : str or Path
        HTML file to write.
    machine : str, optional
        Only this machine (record id or name).
    """
    from volcal.io.atomic import write_text

    write_text(path, fleet_html(history, machine=machine))
    return Path(path)
