"""``volcal history``: every machine and calibration kept; trends and change tests.

The store is chosen by ``--db`` (a URL or an SQLite file), else the ``VOLCAL_DB``
environment variable, else the default file (``docs/history.md``). Nothing of the
history (SQLAlchemy, Alembic, pandas) is imported by any other command. Without the
``history`` extra every subcommand says which extra to install (exit code 2).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

history_app = typer.Typer(help="Calibration history: add, list, show, trend, compare, due, "
                          "fleet, export, verify (SQLite by default, PostgreSQL by URL).",
                          no_args_is_help=True)


@history_app.callback()
def _needs_the_history_extra() -> None:
    # before any subcommand (not for --help): a clear message, exit code 2, when the
    # 'history' extra's libraries are not installed
    from volcal.extras import HISTORY_STORE, require_extra

    require_extra("history", "volcal history", HISTORY_STORE)


DbOption = Annotated[str | None, typer.Option(
    "--db", help="Store: URL (postgresql://..., sqlite:///FILE) or SQLite file; default "
    "$VOLCAL_DB, else ~/.local/share/volcal/history.sqlite.")]


KeyOption = Annotated[Path | None, typer.Option(
    "--private-key", help="Sign the record with this private key (volcal history key new); "
    "default $VOLCAL_HISTORY_KEY, else unsigned.")]


CreateOption = Annotated[bool, typer.Option(
    "--create", help="Make a new store when the --db path (or database) holds none; "
    "without it a path with no history is refused (a typo never makes an empty store).")]


def _open(db: str | None, create: bool = False, private_key: Path | None = None):
    """The history at ``db``; a new store only with ``create`` (said on standard error)."""
    from volcal.history.api import History

    h = History(db, create=create, private_key=private_key)
    if h.store.created:
        _err(f"note: created a new history at {h.store.where}")
    return h


def _given_files_exist(session: Path, model: Path | None, budget: Path | None,
                       certificate: Path | None) -> None:
    """Refuse a missing session, model, budget or certificate before any store is opened.

    ``--create`` would otherwise leave a new, empty history behind a typo. Each is found
    as the add finds it (the same functions, the same messages).
    """
    from volcal.history.record import certificate_file
    from volcal.io.sniff import model_path
    from volcal.session.format import session_toml
    from volcal.uncertainty.budget import read_budget

    session_toml(session)
    if model is not None:
        model_path(model)
    if budget is not None:
        read_budget(budget)
    if certificate is not None:
        certificate_file(certificate)


def _err(text: str) -> None:
    from rich.console import Console
    from rich.markup import escape

    Console(stderr=True, soft_wrap=True).print(escape(text), highlight=False)


def _warn_damaged(h, ids=None) -> None:
    """A warning on stderr for every record read that does not match its own hash.

    Parameters
    ----------
    h : History
        The open history.
    ids : iterable of str, optional
        Only these records (those the command used); default every one read.
    """
    keep = None if ids is None else set(ids)
    for rid, why in sorted(h.store.damaged.items()):
        if keep is None or rid in keep:
            _err(f"warning: record {rid} of the history {h.store.where}: {why}; what is "
                 "shown of it may have been altered (volcal history verify)")


def _current_ids(h, ids) -> set[str]:
    """The records given and their newest corrections (those a comparison used)."""
    from volcal.errors import VolcalInputError

    out = set(ids)
    for rid in ids:
        try:
            out.add(h.store.current(rid).id)
        except VolcalInputError:
            pass
    return out


@history_app.command("add")
def add_cmd(
    session: Annotated[Path, typer.Argument(help="Session folder with readings.")],
    model: Annotated[Path | None, typer.Option(
        "--model", help="Model file identified from it. Omitted: no linear model (a machine "
        "with rotary tests only, or only those of interest): the session's ISO 230-2 "
        "results are stored without the model's.")] = None,
    as_left_of: Annotated[str | None, typer.Option(
        "--as-left-of", help="Id of the as-found calibration (this one measured after "
        "loading compensation tables).")] = None,
    supersedes: Annotated[str | None, typer.Option(
        help="Id of a calibration this one corrects (the old one is kept, marked).")] = None,
    machine: Annotated[str | None, typer.Option(
        help="Machine record id or name, when the session's identity is ambiguous.")] = None,
    force: Annotated[bool, typer.Option(help="Accept a model of other readings.")] = False,
    certificate: Annotated[Path | None, typer.Option(
        "--certificate", help="Folder `volcal report --certificate` wrote for this "
        "calibration (certificate.json): its number is stored; default [calibration] "
        "report_id of the session.")] = None,
    budget: Annotated[Path | None, typer.Option(
        "--budget", help="Uncertainty budget (TOML): the U of every ISO 230-2 parameter, "
        "diagonal and direct-optics result is stored with it (the volumetric indices and "
        "squareness have the model's U either way).")] = None,
    private_key: KeyOption = None,
    db: DbOption = None,
    create: CreateOption = False,
) -> None:
    """Store a calibration; prints the new record's id alone on standard output.

    The same readings and model stored again (a retried add) append nothing: the stored
    record's id is printed, with a note on standard error.
    """
    _given_files_exist(session, model, budget, certificate)  # before a new store is made
    with _open(db, create, private_key) as h:
        rec = h.add(session, model, as_left_of, supersedes, machine, force, certificate,
                    budget)
        if rec.already_stored:
            later = f", superseded by {rec.superseded_by}" if rec.superseded_by else ""
            _err(f"note: this session and model are stored already as {rec.id} "
                 f"(measured {rec.date}{later}); nothing added (--supersedes ID corrects a "
                 "record)")
            typer.echo(rec.id)
            return
        for n in rec.payload.get("notes", []):
            _err(f"note: {n}")
        for w in rec.payload.get("warnings", []):
            _err(f"warning: {w}")
        typer.echo(rec.id)


@history_app.command("add-etalon")
def add_etalon_cmd(
    file: Annotated[Path, typer.Argument(help="Etalon exchange file (Vendor variant).")],
    session: Annotated[Path, typer.Option(help="Session folder naming the machine "
                                          "([machine]) and the date ([calibration]).")],
    date: Annotated[str | None, typer.Option(help="Date of measurement (ISO 8601).")] = None,
    machine: Annotated[str | None, typer.Option(help="Machine record id or name.")] = None,
    private_key: KeyOption = None,
    db: DbOption = None,
    create: CreateOption = False,
) -> None:
    """Store another system's result (Etalon exchange file); prints the record id."""
    from volcal.history.etalon import read_etalon

    read_etalon(file)  # the file and the session as the add reads them, before a new store
    _given_files_exist(session, None, None, None)
    with _open(db, create, private_key) as h:
        rec = h.add_etalon(file, session, date, machine)
        if rec.payload.get("not_mapped"):
            _err("note: blocks kept in the stored file but not mapped to volcal's 21 errors: "
                 + ", ".join(rec.payload["not_mapped"]))
        typer.echo(rec.id)


@history_app.command("export-etalon")
def export_etalon_cmd(
    record: Annotated[str, typer.Argument(help="Calibration record id.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Exchange file to write.")],
    db: DbOption = None,
) -> None:
    """Write a calibration's identified functions as an Etalon exchange file."""
    from volcal.errors import VolcalInputError
    from volcal.history.compare import load_record_model
    from volcal.history.etalon import write_etalon
    from volcal.io.paths import check_output_file

    check_output_file(output)
    with _open(db) as h:
        r = h.show(record)
        model = load_record_model(h.store, r.id)
        _warn_damaged(h, {r.id, record})
    if model is None:
        raise VolcalInputError(f"{r.id} has no volcal model to export")
    write_etalon(model.errors, output, f"volcal history {r.id} ({r.machine_name}, {r.date})")
    typer.echo(str(output))


@history_app.command("export-qif")
def export_qif_cmd(
    output: Annotated[Path, typer.Option("-o", "--output", help="QIF file to write.")],
    record: Annotated[str | None, typer.Argument(
        help="Calibration record id (or give --model).")] = None,
    model: Annotated[Path | None, typer.Option(
        "--model", help="Write this model file instead of a record (no store needed).")] = None,
    xsd: Annotated[Path | None, typer.Option(
        "--xsd", help="Validate the written file against this QIFDocument.xsd (or a folder "
        "holding QIFApplications/); default $VOLCAL_QIF_XSD when set.")] = None,
    db: DbOption = None,
) -> None:
    """Write a calibration's 21 errors as a QIF 3 document (Cartesian CMM FPS test)."""
    from volcal.errors import VolcalInputError
    from volcal.history.qif import QifMachine, due_date, find_xsd, validate_qif, write_qif

    if (record is None) == (model is None):
        raise VolcalInputError("give a calibration record id or --model FILE (one of them)")
    from volcal.io.paths import check_output_file

    check_output_file(output)
    if model is not None:
        from volcal.identify.modelfile import load_model

        m = load_model(model)
        travel = [(float(n[0]), float(n[-1])) for n in m.errors.nodes]
        write_qif(m.errors, output, QifMachine(name=m.errors.name, travel_mm=travel),
                  f"volcal model {model.name}")
    else:
        from volcal.history.compare import load_record_model
        from volcal.history.due import machine_interval

        with _open(db) as h:
            r = h.show(record)
            if r.kind != "calibration":
                raise VolcalInputError(f"{r.id} is a {r.kind} record, not a calibration "
                                       "(volcal history list)")
            m = load_record_model(h.store, r.id)
            days = machine_interval([h.store.record(r.machine_id),  # its own records
                                     *h.store.records(machine_id=r.machine_id)]
                                    if r.machine_id else [], r.machine_id)
            _warn_damaged(h, {r.id, record})
        if m is None:
            raise VolcalInputError(f"{r.id} has no volcal model to export")
        ident = r.payload.get("machine", {})
        info = QifMachine(name=r.machine_name, make=ident.get("make"),
                          model=ident.get("model"), serial=ident.get("serial"),
                          travel_mm=ident.get("travel_mm"), location=ident.get("location"),
                          date=r.date, due=due_date(r.date, days))
        import uuid

        # one record, one document id: exporting it again gives the same QPId
        qpid = str(uuid.uuid5(uuid.NAMESPACE_URL, f"volcal-history:{r.hash}"))
        write_qif(m.errors, output, info, f"volcal history {r.id}", qpid)
    schema = find_xsd([xsd] if xsd is not None else None)
    if xsd is not None and schema is None:
        raise VolcalInputError(f"--xsd {xsd}: no QIFDocument.xsd there")
    if schema is not None:
        problems = validate_qif(output, schema)
        if problems:
            raise VolcalInputError("the written file does not validate against "
                                   f"{schema}: " + "; ".join(problems[:5]), output)
        _err(f"validates against {schema}")
    typer.echo(str(output))


@history_app.command("list")
def list_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="JSON array of records.")] = False,
    all_records: Annotated[bool, typer.Option("--all", help="Every record: also the "
                                              "machines and their intervals (no date of "
                                              "measurement).")] = False,
    certificate: Annotated[str | None, typer.Option(
        "--certificate", help="Only the calibration of this certificate number.")] = None,
    machine: Annotated[str | None, typer.Option(
        "--machine", help="Only this machine's records (name or record id).")] = None,
    db: DbOption = None,
) -> None:
    """The calibrations by date of measurement, superseded ones marked.

    With --all every record, in the order stored.
    """
    from volcal.history.api import by_date

    with _open(db) as h:
        if machine is None:  # streamed: a chunk of records in memory at a time
            recs = h.stream(all_records)
        else:  # the machine's own records only (indexed), its machine record first
            mid = h.machine_id(machine)
            recs = [h.store.record(mid), *h.store.records(machine_id=mid)]
            if not all_records:  # the records with a date of measurement
                recs = by_date([r for r in recs if r.kind == "calibration"])
        if certificate is not None:
            recs = [r for r in recs if r.report_id == certificate.strip()]
            if not recs:
                _warn_damaged(h)
                _err(f"no calibration of certificate {certificate!r} in the history")
                raise typer.Exit(1)
        if as_json:
            _echo_json_array({"id": r.id, "kind": r.kind, "machine": r.machine_name,
                              "machine_id": r.machine_id or (r.id if r.kind == "machine"
                                                             else None),
                              "date": r.date, "created": r.created,
                              "supersedes": r.supersedes, "superseded_by": r.superseded_by,
                              "superseded": r.superseded_by is not None,
                              "as_left_of": r.as_left_of, "report_id": r.report_id,
                              "hash": r.hash} for r in recs)
        else:
            typer.echo("id\tkind\tmachine\tdate of measurement\tnote")
            for r in recs:
                note = []
                if r.superseded_by:
                    note.append(f"superseded by {r.superseded_by}")
                if r.supersedes:
                    note.append(f"corrects {r.supersedes}")
                if r.as_left_of:
                    note.append(f"as-left of {r.as_left_of}")
                if r.report_id:
                    note.append(f"certificate {r.report_id}")
                typer.echo(f"{r.id}\t{r.kind}\t{r.machine_name}\t{r.date or '-'}\t"
                           f"{'; '.join(note)}")
        _warn_damaged(h)


def _echo_json_array(items) -> None:
    """``json.dumps(list(items), indent=1)``, written an item at a time (streamed)."""
    first = True
    for item in items:
        typer.echo("[" if first else ",")
        typer.echo(" " + json.dumps(item, indent=1).replace("\n", "\n "), nl=False)
        first = False
    typer.echo("[]" if first else "\n]")


@history_app.command("show")
def show_cmd(
    record: Annotated[str, typer.Argument(help="Record id.")],
    as_json: Annotated[bool, typer.Option("--json", help="JSON.")] = False,
    db: DbOption = None,
    units: Annotated[str, typer.Option(
        "--units", help="Angles (rotary axes, squareness: the results stored in urad) in "
        "urad or arcsec.")] = "urad",
) -> None:
    """A record (the newest correction of it), its results and files."""
    from volcal.standards.iso230_2_rotary import check_units

    check_units(units)
    with _open(db) as h:
        r = h.show(record)
        _warn_damaged(h, {r.id, record})
    if as_json:
        d = r.to_dict()
        if isinstance(d.get("results"), dict):
            d["results"] = {k: _in_units(v, units) for k, v in d["results"].items()}
        typer.echo(json.dumps(d, indent=1, default=str))
        return
    typer.echo(f"{r.id} ({r.kind}) of {r.machine_name}, measured {r.date or '-'}, "
               f"stored {r.created}")
    if r.id != record:
        typer.echo(f"(the newest correction of {record})")
    cal = r.payload.get("calibration") or {}
    for k in ("operator", "customer", "laboratory"):
        if k in cal:
            typer.echo(f"{k}: {cal[k]}")
    if r.report_id:
        typer.echo(f"certificate: {r.report_id}")
    for e in r.equipment:
        typer.echo("equipment: " + ", ".join(f"{k} {v}" for k, v in e.items()))
    if r.results:
        typer.echo("result\tvalue\tU (k=2)\tunit")
        for name, v in r.results.items():
            v = _in_units(v, units)
            val = "-" if v["value"] is None else f"{v['value']:.4f}"
            u = "-" if v["U"] is None else f"{v['U']:.4f}"
            typer.echo(f"{name}\t{val}\t{u}\t{v['unit']}")
    for f in r.files:
        typer.echo(f"file {f['role']}: {f['name']} sha256 {f['sha256'][:16]}...")
    typer.echo(f"hash {r.hash}")
    if r.signature:
        typer.echo(f"signed by key {r.key_id} (volcal history verify --public-key FILE "
                   "checks it)")


def _in_units(row: dict, units: str) -> dict:
    """A result row (``value``, ``U``, ``unit``) with an angle in ``units`` (display)."""
    from volcal.standards.iso230_2_rotary import UNITS

    if units == "urad" or row.get("unit") != "urad":
        return row
    f = UNITS[units]
    return {**row, "unit": units,
            **{k: None if row.get(k) is None else float(row[k]) * f for k in ("value", "U")}}


@history_app.command("trend")
def trend_cmd(
    machine: Annotated[str, typer.Argument(help="Machine name or record id.")],
    parameter: Annotated[str, typer.Option(
        help="Result name (X.A, linear-x1.R, V.E_VXYZ, EC0Y ...) or function at a "
        "position (EXX@400).")],
    plot: Annotated[Path | None, typer.Option(help="Also write a figure (.png, .svg, "
                                              ".pdf) with the U bands.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="JSON rows.")] = False,
    db: DbOption = None,
    units: Annotated[str, typer.Option(
        "--units", help="An angle (a rotary axis' C.A, a squareness: stored in urad) in "
        "urad or arcsec.")] = "urad",
) -> None:
    """One parameter over the calibrations of a machine, with its U (k = 2)."""
    from volcal.history.trend import axis_lines_note, trend
    from volcal.standards.iso230_2_rotary import check_units

    check_units(units)
    if plot is not None:  # refused before the store is read
        from volcal.plot.trend import check_trend_plot_path

        check_trend_plot_path(plot)
    with _open(db) as h:
        rows = [_in_units(r, units) for r in trend(h, machine, parameter)]
        _warn_damaged(h, {r["id"] for r in rows})
        note = axis_lines_note(h, rows, parameter)
    if note is not None:
        _err(f"note: {note}")
    if as_json:
        typer.echo(json.dumps(rows, indent=1))
    else:
        unit = next((r["unit"] for r in rows if r["unit"]), "")
        typer.echo(f"id\tdate\t{parameter} [{unit}]\tU (k=2) [{unit}]")
        for r in rows:
            v = "-" if r["value"] is None else f"{r['value']:.4f}"
            u = "-" if r["U"] is None else f"{r['U']:.4f}"
            typer.echo(f"{r['id']}\t{r['date']}\t{v}\t{u}")
    if plot is not None:
        from volcal.plot.trend import write_trend_plot

        write_trend_plot(rows, parameter, machine, plot)
        _err(f"figure: {plot}")


@history_app.command("compare")
def compare_cmd(
    first: Annotated[str, typer.Argument(help="Earlier calibration id.")],
    second: Annotated[str, typer.Argument(help="Later calibration id.")],
    level: Annotated[float, typer.Option(
        help="Family-wise false-alarm level of the function tests.")] = 0.05,
    as_json: Annotated[bool, typer.Option("--json", help="JSON array of entries.")] = False,
    db: DbOption = None,
    units: Annotated[str, typer.Option(
        "--units", help="Angles (rotary axes, squareness: stored in urad) in urad or "
        "arcsec.")] = "urad",
) -> None:
    """Has the machine changed? Each result and identified function against its U."""
    from dataclasses import replace

    from volcal.history.compare import compare, pair_notes
    from volcal.standards.iso230_2_rotary import UNITS, check_units

    check_units(units)
    with _open(db) as h:
        entries = compare(h.store, first, second, level)
        _warn_damaged(h, _current_ids(h, (first, second)))
        for note in pair_notes(h.store, first, second):
            _err(f"note: {note}")
    if units != "urad":  # display: the differences of angles and their U
        f = UNITS[units]
        entries = [replace(e, difference=e.difference * f, unit=units,
                           U=None if e.U is None else e.U * f)
                   if e.unit == "urad" and e.test != "chi-square" else e for e in entries]
    if as_json:
        typer.echo(json.dumps([e.to_dict() for e in entries], indent=1))
        return
    typer.echo("name\tdifference\tU (k=2)\tunit\tverdict\ttest")
    for e in entries:
        u = "-" if e.U is None else f"{e.U:.4f}"
        if e.test == "chi-square":
            extra = e.reason or (f"chi2 {e.statistic:.1f} > {e.threshold:.1f}" if e.changed
                                 else (f"chi2 {e.statistic:.1f} <= {e.threshold:.1f}"
                                       if e.statistic is not None else ""))
            if e.changed and e.U is not None and abs(e.difference) <= e.U:
                extra += (f" (decided by the joint test over {e.dof} determined "
                          "combinations; |difference| <= U at the node shown)")
            test = f"{e.test} {extra}".rstrip()
        elif e.U is not None:  # a result against the combined U of the two calibrations
            test = f"|d| {abs(e.difference):.4f} {'>' if e.changed else '<='} U {e.U:.4f}"
        else:  # a result without a stored U (the two tests are chi-square and |d| > U)
            test = f"not tested: {e.reason}"
        typer.echo(f"{e.name}\t{e.difference:+.4f}\t{u}\t{e.unit}\t{e.verdict}\t{test}")
    n = sum(1 for e in entries if e.changed)
    typer.echo(f"{n} of {sum(1 for e in entries if e.changed is not None)} decided entries "
               f"changed (functions: family-wise level {level:g})")
    untested = sum(1 for e in entries if e.U is None and e.test == "|d| > U")
    if untested:
        typer.echo(f"{untested} results not tested for want of a stored U: `volcal history "
                   "add --budget FILE` stores the U of the ISO 230-2 and diagonal results")


@history_app.command("interval")
def interval_cmd(
    machine: Annotated[str, typer.Argument(help="Machine name or record id.")],
    days: Annotated[int, typer.Argument(min=1, help="Calibration interval [days].")],
    private_key: KeyOption = None,
    db: DbOption = None,
) -> None:
    """Set a machine's calibration interval (appends a record)."""
    from volcal.history.store import NewRecord

    with _open(db, private_key=private_key) as h:
        mid = h.machine_id(machine)
        rec = h.store.append(NewRecord("interval", {"interval_days": days}, machine_id=mid))
    typer.echo(rec.id)


@history_app.command("due")
def due_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="JSON rows.")] = False,
    db: DbOption = None,
) -> None:
    """Next calibration date per machine and test, overdue first."""
    from volcal.history.due import due

    with _open(db) as h:
        rows = due(h)
        _warn_damaged(h)
    if as_json:
        typer.echo(json.dumps(rows, indent=1))
        return
    typer.echo("machine\ttest\tlast\tnext due\tinterval [days]\tstatus")
    for r in rows:
        st = f"OVERDUE by {r['overdue_days']} days" if r["overdue_days"] else "ok"
        typer.echo(f"{r['machine']}\t{r['test']}\t{r['last'] or '-'}\t{r['next']}\t"
                   f"{r['interval_days']}\t{st}")


@history_app.command("fleet")
def fleet_cmd(
    output: Annotated[Path, typer.Option("-o", "--output", help="HTML file.")] = Path(
        "fleet.html"),
    machine: Annotated[str | None, typer.Option(
        "--machine", help="Only this machine (name or record id).")] = None,
    db: DbOption = None,
) -> None:
    """One HTML page: every machine, its last calibration, E_VXYZ ± U, trend, due date."""
    from volcal.history.fleet import write_fleet
    from volcal.io.paths import check_output_file

    check_output_file(output)
    with _open(db) as h:
        path = write_fleet(h, output, machine)
        _warn_damaged(h)
    typer.echo(str(path))


@history_app.command("export")
def export_cmd(
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the Parquet "
                                         "files.")],
    db: DbOption = None,
    replace: Annotated[bool, typer.Option(
        "--replace", help="The output folder holds files volcal did not write there: move "
        "them into OUTPUT/backup/<UTC time>/ instead of refusing.")] = False,
) -> None:
    """Every table as Parquet files (readable by DuckDB or pandas)."""
    from volcal.cli._common import note_moved
    from volcal.history.export import export_parquet, exported_files
    from volcal.io.paths import prepare_output_folder

    with _open(db) as h:  # a path without a history is refused before the folder is touched
        moved = prepare_output_folder(output, "history export",
                                      lambda p: bool(exported_files(p)),
                                      written=exported_files, replace=replace)
        if moved is not None:
            note_moved(output, moved)
        for p in export_parquet(h, output):
            typer.echo(str(p))
        _warn_damaged(h)


@history_app.command("verify")
def verify_cmd(
    db: DbOption = None,
    public_key: Annotated[list[Path] | None, typer.Option(
        "--public-key", help="Also check every record's signature against this public key "
        "(PEM; repeat for several keys).")] = None,
    head: Annotated[str | None, typer.Option(
        "--head", help="A head hash kept elsewhere (printed by an earlier verify): confirm "
        "it is still on the chain with every record up to it unchanged.")] = None,
) -> None:
    """Check the hash chain; exit status 0 only when it is intact. Prints the head hash."""
    import re

    from volcal.errors import VolcalInputError

    if head is not None:
        head = head.strip().lower()
        if not re.fullmatch(r"[0-9a-f]{64}", head):
            raise VolcalInputError(f"--head {head}: expected the 64 hex digits of a head "
                                   "hash printed by volcal history verify")
    with _open(db) as h:
        chk = h.store.check()
        sig = h.verify_signatures(public_key) if chk.ok and public_key else None
    kept = None if head is None else chk.hashes.get(head)
    if not chk.ok:
        typer.echo(f"chain BROKEN at {chk.first}: {chk.why}; last good head {chk.head}")
        if kept is not None:
            typer.echo(f"the kept head is record {kept}: it and every record before it "
                       "unchanged")
        raise typer.Exit(1)
    typer.echo(f"chain intact: {chk.n} records; head {chk.head}")
    for ids in chk.duplicates:
        typer.echo(f"note: {', '.join(ids)} hold the same readings and model (added more "
                   "than once before schema revision 0004 refused it; records are never "
                   "deleted, a retried add returns the newest)")
    if head is not None:
        if kept is None:
            typer.echo(f"kept head {head} is NOT on the chain: a record up to it was "
                       "rewritten or deleted since that head was kept")
            raise typer.Exit(1)
        typer.echo(f"kept head is record {kept} of {chk.n}: it and every record before it "
                   f"unchanged; {chk.n - kept} records appended since")
    if sig is not None:
        _report_signatures(sig)


def _report_signatures(sig) -> None:
    """The line of ``verify --public-key``; exit status 1 when a record is not vouched for."""
    if sig.ok:
        typer.echo(f"signatures valid: every record up to {sig.last_signed} is vouched for "
                   f"by the key ({sig.signed} of {sig.n} records signed)")
        return
    where = f" at {sig.first_bad}" if sig.first_bad else ""
    typer.echo(f"signatures BROKEN{where}: {sig.why}")
    raise typer.Exit(1)


key_app = typer.Typer(help="Key pair that signs the history's records (optional).",
                      no_args_is_help=True)
history_app.add_typer(key_app, name="key")


@key_app.command("new")
def key_new_cmd(
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Folder for history-key.pem (private, 0600) and "
        "history-key.pub.pem; default $XDG_CONFIG_HOME/volcal (~/.config/volcal).")] = None,
) -> None:
    """Make an Ed25519 key pair; prints the private key's path (for VOLCAL_HISTORY_KEY)."""
    from volcal.history.signing import KEY_ENV, new_key_pair

    private, public, kid = new_key_pair(output)
    _err(f"key {kid}: public key {public} (give it to whoever verifies: volcal history "
         f"verify --public-key {public}); keep the private key to yourself and sign with "
         f"--private-key or {KEY_ENV}")
    typer.echo(str(private))


def register(app: typer.Typer) -> None:
    """Add the ``history`` command group."""
    app.add_typer(history_app, name="history")
