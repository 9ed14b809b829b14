"""``volcal identify`` and ``volcal predict``."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from volcal import defaults as D
from volcal.cli._common import (
    is_stdout,
    message_console,
    parse_vector,
    print_session_notes,
    write_output,
)
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error


def identify_cmd(
    session: Path = typer.Argument(..., help="Measured session folder."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (MODEL.json); "
                                "- writes it to standard output."),
    prior: str = typer.Option("smooth", help="smooth (Bayesian, default) or none (min-norm LS)."),
    noise_um: float | None = typer.Option(None, help="Stated repeatability [um] (default: "
                                          "estimated)."),
    roll: str = typer.Option(D.ROLL, help="estimate, or zero (the rolls EAX, EBY, ECZ "
                             "fixed to zero)."),
    known: Path | None = typer.Option(None, help="CSV of errors measured separately "
                                      "(axis,position_mm and any of EX_um..EC_urad, only "
                                      "the axes measured; or a full error table): those "
                                      "functions are held fixed."),
    known_u: float | None = typer.Option(None, help="Standard uncertainty of the --known "
                                         "functions [um or urad]: use them as priors instead "
                                         "of fixing them."),
    monte_carlo: int = typer.Option(0, min=0, help="Monte Carlo trials (GUM S1) of the noise "
                                    "propagation to the volumetric error; 0 = off."),
    drift: bool = typer.Option(False, help="Estimate a linear drift per measurement."),
    measurements: str | None = typer.Option(None, help="Comma-separated measurement ids to use."),
    max_nodes: int = typer.Option(41, min=3, max=2001, help="Nodes per axis at most (problem "
                                  "size; the parameter count stops growing there)."),
    robust: bool = typer.Option(False, help="Down-weight the readings the outlier check "
                                "flags (weight 1/z^2) and fit again; they stay listed."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML, `volcal budget "
                                       "--template`): its systematic inputs (wavelength, "
                                       "air per set-up, material per axis, the scale "
                                       "of each direct optic) propagated "
                                       "through the fit, kept apart in the model file."),
) -> None:
    """Identify the machine's errors from the session; write MODEL.json."""
    from volcal.identify import IdentifyOptions, identify
    from volcal.identify.modelfile import binary_path
    from volcal.io.paths import check_output_file
    from volcal.session.format import read_session

    console = message_console(output)  # stderr when the model goes to stdout
    if not is_stdout(output):
        check_output_file(output)
        check_output_file(binary_path(output))  # MODEL.npz, written beside it
    if noise_um is not None and not (np.isfinite(noise_um) and noise_um > 0):
        raise VolcalInputError(f"--noise-um {noise_um}: expected a positive repeatability [um]")
    if known_u is not None and known is None:
        raise VolcalInputError("--known-u needs --known (the error table it applies to)")
    if known_u is not None and not (np.isfinite(known_u) and known_u > 0):
        raise VolcalInputError(f"--known-u {known_u}: expected a positive uncertainty")
    ids = None if measurements is None else [m.strip() for m in measurements.split(",")
                                             if m.strip()]
    if ids is not None and not ids:
        raise VolcalInputError(f"--measurements {measurements!r}: no measurement id given")
    b = None
    if budget is not None:
        from volcal.uncertainty.budget import read_budget

        b = read_budget(budget)
    s = read_session(session)
    print_session_notes(s)
    if ids is not None:
        have = {m.id for m in s.measurements}
        missing = [i for i in ids if i not in have]
        if missing:
            raise VolcalInputError(f"--measurements: no measurement {', '.join(missing)} in the "
                                   f"session (it has {', '.join(sorted(have))})",
                                   s.path / "session.toml" if s.path else session)
    known_d: dict = {}
    if known is not None:
        from volcal.session.errortable import read_known_functions

        for name, (pos, vals) in read_known_functions(known).items():
            known_d[name] = (pos, vals) if known_u is None else (pos, vals, known_u)
    opts = IdentifyOptions(prior=prior, noise_um=noise_um, roll=roll, known=known_d, drift=drift,
                           measurement_ids=ids, max_nodes=max_nodes, robust=robust)
    with console.status("identifying..."):
        res = identify(s, opts)
        if monte_carlo > 0:
            from volcal.identify import monte_carlo as mc
            from volcal.identify.identifiability import grid_points

            q = grid_points(res.design)
            _, sd, lo, hi = mc(res, q, monte_carlo)
            res.fit["monte_carlo"] = {
                "trials": monte_carlo,
                "points": int(q.shape[0]),
                "max_std_um": float(sd.max()),
                "rms_std_um": float(np.sqrt(np.mean(sd**2))),
                "max_95_half_width_um": float(((hi - lo) / 2).max()),
                "note": "noise part only (readings redrawn, same hyperparameters); the "
                        "analytic uncertainty adds the prior part",
            }
        if b is not None:
            from volcal.identify.systematic import attach_systematic

            attach_systematic(res, b, str(budget))
    if is_stdout(output):  # one file on standard output: format 2, everything as text
        import json

        write_output(output, json.dumps(res.to_single_file_dict(), indent=1,
                                        allow_nan=False) + "\n")
    else:
        res.to_json(output)  # MODEL.npz (covariance, readings) first, then MODEL.json
    f = res.fit
    console.print(f"{f['n_readings']} readings, {f['n_parameters']} parameters, "
                  f"residual {f['sigma_residual_um']:.3f} um ({f['method']})")
    for msg in res.report.messages:
        console.print(f"- {msg}", highlight=False, markup=False)
    if b is not None:
        from volcal.identify.identifiability import grid_points

        q = grid_points(res.design)
        un = res.predict(q, systematic=False)[1]
        ut = res.predict(q)[1]
        us = np.sqrt(np.maximum(ut**2 - un**2, 0.0))
        console.print(f"volumetric error uncertainty over the measured grid, largest u: noise "
                      f"and prior {un.max():.3f} um, systematic (budget: "
                      f"{len(res.sys_labels)} inputs) {us.max():.3f} um, both "
                      f"{ut.max():.3f} um", highlight=False)
        if (any(k.endswith("_scale_pct") for k in b.defaulted)
                and any(lab.startswith("optics scale") for lab in res.sys_labels)):
            console.print("note: no [optics] scale keys in the budget file: the direct optics' "
                          "scale errors are the data-sheet defaults (volcal budget --template)",
                          highlight=False, markup=False)
    console.print("model -> " + ("standard output" if is_stdout(output)
                                 else f"{output} (+ {binary_path(output).name})"),
                  highlight=False)


def _points_spec():
    from volcal.io.table import Column, TableSpec

    return TableSpec(tuple(Column(c, abs_max=1e7) for c in ("x_mm", "y_mm", "z_mm")),
                     min_rows=0, what="points file")


def _read_points(path: Path) -> np.ndarray:
    """Read the points CSV ``x_mm,y_mm,z_mm`` [mm] through :func:`volcal.io.table.read_table`."""
    from volcal.io.table import read_table

    t = read_table(path, _points_spec())
    if len(t) == 0:
        raise VolcalInputError("no points", path, 2)
    return np.stack([t[c].astype(float) for c in ("x_mm", "y_mm", "z_mm")], axis=1)


def predict_cmd(
    model: Path = typer.Argument(..., help="Model file (MODEL.json)."),
    points: Path = typer.Option(..., help="CSV with x_mm,y_mm,z_mm."),
    output: Path = typer.Option(..., "-o", "--output", help="CSV to write; - writes it to "
                                "standard output."),
    tool_offset: str = typer.Option("0,0,0", help="Tool offset x,y,z [mm]."),
    session: Path | None = typer.Option(None, help="Session folder the model should belong "
                                        "to: refused if name, chain, travel or readings "
                                        "differ."),
    force: bool = typer.Option(False, "--force", help="With --session: use the model even if "
                               "it was identified from another session."),
) -> None:
    """Predict the volumetric error and its uncertainty at points."""
    from volcal.identify import load_model
    from volcal.identify.modelfile import check_model_file_session
    from volcal.io.paths import check_output_file

    console = message_console(output)  # stderr when the CSV goes to stdout
    if not is_stdout(output):
        check_output_file(output)
    m = load_model(model)
    m.require_uncertainty("volcal predict (its columns ux_um, uy_um, uz_um)", model)
    for d in check_model_file_session(model, session, force):
        err_console.print(f"[yellow]warning[/] --force: {d}", highlight=False)
    q = _read_points(points)
    travel = m.errors.travel
    for j, col in enumerate(("x_mm", "y_mm", "z_mm")):
        out = np.flatnonzero((q[:, j] < travel[j, 0] - 1e-9) | (q[:, j] > travel[j, 1] + 1e-9))
        if out.size:
            raise VolcalInputError(f"{q[out[0], j]:g} mm is outside the model's travel "
                                   f"{travel[j, 0]:g}..{travel[j, 1]:g} mm (no extrapolation)",
                                   points, int(out[0]) + 2, col)
    e, u = m.predict(q, parse_vector(tool_offset, "--tool-offset"))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["x_mm", "y_mm", "z_mm", "ex_um", "ey_um", "ez_um", "ux_um", "uy_um", "uz_um"])
    for i in range(q.shape[0]):
        w.writerow([f"{v:.6g}" for v in q[i]] + [f"{v:.4f}" for v in e[i]]
                   + [f"{v:.4f}" for v in u[i]])
    write_output(output, buf.getvalue())
    console.print(f"{q.shape[0]} points -> "
                  + ("standard output" if is_stdout(output) else str(output)), highlight=False)


def advise_cmd(
    session: Path = typer.Argument(..., help="Planned (or measured) session folder."),
    roll: str = typer.Option(D.ROLL, help="estimate, or zero (the rolls EAX, EBY, ECZ "
                             "fixed to zero)."),
) -> None:
    """Before measuring: what the planned tests will and will not determine."""
    from volcal.identify import IdentifyOptions, advise
    from volcal.session.format import read_session

    s = read_session(session, require_deviation=False)
    with console.status("analysing the design..."):
        rep = advise(s, IdentifyOptions(roll=roll))
    for msg in rep.messages:
        console.print(f"- {msg}", highlight=False, markup=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("advise")(advise_cmd)
    app.command("identify")(identify_cmd)
    app.command("predict")(predict_cmd)
