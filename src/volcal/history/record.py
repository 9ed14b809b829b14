"""A calibration record from a session folder and its model: files, results, machine.

What is stored: every file of the session folder (``session.toml``, the measurement
CSVs; ``backup/`` and ``truth/`` are left out) with its sha256, the model file and the
files beside it that share its stem (a binary covariance part), and the results with
their expanded uncertainty where volcal has one: ISO 230-2 parameters of every linear
test (``<id>.<key>``, and ``<axis>.<key>`` for the first test of each axis), those of
every rotary test in urad (``<id>.<key>``, ``C.A`` for the first test of the C axis),
ISO 230-6 results, the volumetric indices of the model (``V.<key>``) and the squareness errors
(``EC0Y``...; U = 2 u from the model's covariance); with probe_sphere or r_test tests, the
rotary axes' location errors the poses determine (``EX0C``...; U = 2 u of ``volcal
locate``) and the RMS scatter of the sphere centre (``<chain>.scatter_before``,
``<chain>.scatter_after`` [um]).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from volcal.history.store import NewRecord

#: The diagonals' stored values that describe the test rather than measure the machine,
#: with their units (before session 18 stored as "um"); ``history compare`` does not test
#: them.
DESCRIPTOR_UNITS = {"length_mm": "mm", "points_measured": "points",
                    "points_planned": "points"}

ISO230_2_KEYS = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up", "R_down",
                 "B", "B_mean")
SKIP_DIRS = ("backup", "truth")


def session_files(folder: Path) -> list[tuple[str, str, bytes]]:
    """Every file of a session folder (``backup/``, ``truth/`` and hidden files left out).

    Parameters
    ----------
    folder : Path
        The session folder.
    """
    out = []
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder)
        if not p.is_file() or rel.parts[0] in SKIP_DIRS or rel.parts[0].startswith("."):
            continue
        out.append(("session", rel.as_posix(), p.read_bytes()))
    return out


def model_files(model: Path) -> list[tuple[str, str, bytes]]:
    """The model file and the files beside it that share its stem (its binary part).

    Parameters
    ----------
    model : Path
        The model file.
    """
    out = [("model", model.name, model.read_bytes())]
    for p in sorted(model.parent.glob(model.stem + ".*")):
        if p != model and p.is_file() and p.suffix != ".json":
            out.append(("model-part", p.name, p.read_bytes()))
    return out


def _num(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if f == f else None


def results_of(session: Any, model: Any, budget: Any = None, evaluation: Any = None
               ) -> list[tuple[str, float | None, float | None, str]]:
    """Named results with U (None where volcal has none) of a session and its model.

    The session is evaluated once (:func:`volcal.standards.session.evaluate_session`,
    with the model's uncertainty where it has a covariance and the direct optics) unless
    that evaluation is given; the rows are :func:`results_from_evaluation`'s.

    Parameters
    ----------
    session : Session
        The session with readings.
    model : IdentificationResult or None
        Its model.
    budget : Budget, optional
        Uncertainty budget (:func:`volcal.uncertainty.budget.read_budget`): the U of every
        ISO 230-2 parameter, diagonal and direct-optics result. Without it those have
        none; the volumetric indices and the squareness have the model's U either way.
    evaluation : SessionEvaluation, optional
        The session's evaluation, already made (the report's): stored as it is.
    """
    if evaluation is None:
        from volcal.standards.model_uncertainty import has_covariance
        from volcal.standards.session import evaluate_session

        evaluation = evaluate_session(
            session, model, model_uncertainty=model is not None and has_covariance(model),
            budget=budget, optics=True)
    rows = results_from_evaluation(evaluation, model)
    names = {r[0] for r in rows}
    return rows + [r for r in location_rows(session, model) if r[0] not in names]


def location_rows(session: Any, model: Any = None
                  ) -> list[tuple[str, float | None, float | None, str]]:
    """The location errors of a session's probe_sphere and r_test tests as stored results.

    Each determined location error by its ISO 230-1 name (``EX0C``; a second chain of the
    session prefixes its code, ``FXYZCA.EX0C``) with U = 2 u, identified as ``volcal
    locate`` and the report identify it, with the linear axes' errors of ``model``
    (:func:`volcal.identify.location_evaluation.location_results`); errors held at zero
    (redundant) are not stored. None without probe_sphere or r_test tests.

    Parameters
    ----------
    session : Session
        The session.
    model : IdentificationResult, optional
        Its model (the linear axes' errors); None: perfect linear axes.
    """
    if not any(m.kind in ("probe_sphere", "r_test") for m in session.measurements):
        return []
    from volcal.identify.location_evaluation import locate_session, location_results

    return location_results(locate_session(session, model))


def results_from_evaluation(ev: Any, model: Any = None
                            ) -> list[tuple[str, float | None, float | None, str]]:
    """The rows ``name, value, U, unit`` of a session's evaluation, as stored.

    What the evaluation gives, never recomputed: ISO 230-2 parameters with the budget's U
    (:attr:`SessionEvaluation.with_budget`), the diagonals' results (``E_D`` with its
    U), the volumetric indices with the model's U (noise and systematic parts), the
    squareness errors with theirs (:attr:`SessionEvaluation.model_indices`; without it,
    U = 2 u from the model's covariance), and the direct optics' results with their U
    (``<id>.straightness``, ``<id>.straightness_end_point``, ``<id>.slope``,
    ``<id>.slope_end_point``, ``<id>.angular_deviation``, ``optics.EC0Y`` and
    ``optics.EC0Y_end_point`` for an optical-square pair). U is None where the
    evaluation has none.

    Parameters
    ----------
    ev : SessionEvaluation
        :func:`volcal.standards.session.evaluate_session`'s result.
    model : IdentificationResult, optional
        The model (its squareness when the evaluation has no model indices).
    """
    rows: list[tuple[str, float | None, float | None, str]] = []
    seen_axes: set[str] = set()
    stated = ev.with_budget  # the tests evaluated with the budget: results and U together
    for mid, res in ev.iso230_2.items():
        d = stated[mid].to_dict() if mid in stated else res.to_dict()
        axis = ev.axis[mid].upper()
        for key in ISO230_2_KEYS:
            if key not in d:
                continue
            value, u = _num(d[key]), _num(d.get(f"U_{key}"))
            rows.append((f"{mid}.{key}", value, u, "um"))
            if axis not in seen_axes:
                rows.append((f"{axis}.{key}", value, u, "um"))
        seen_axes.add(axis)
    seen_rotary: set[str] = set()
    for mid, res in getattr(ev, "rotary", {}).items():  # rotary axes: angles [urad]
        d = res.to_dict("urad")
        axis = str(res.axis).upper()
        for key in ISO230_2_KEYS:
            value, u = _num(d.get(key)), _num(d.get(f"U_{key}"))
            rows.append((f"{mid}.{key}", value, u, "urad"))
            if axis not in seen_rotary:  # C.A: the accuracy of the C axis' first test
                rows.append((f"{axis}.{key}", value, u, "urad"))
        seen_rotary.add(axis)
    for mid, res in ev.iso230_6.items():
        d = stated[mid].to_dict() if mid in stated else (
            res.to_dict() if hasattr(res, "to_dict") else {})
        for key, value in d.items():
            if key.startswith(("U_", "u_", "k_")) or key == "k":
                continue
            if isinstance(value, int | float) and not isinstance(value, bool):
                rows.append((f"{mid}.{key}", _num(value), _num(d.get(f"U_{key}")),
                             DESCRIPTOR_UNITS.get(key, "um")))
    if ev.volumetric is not None:
        v = ev.volumetric.to_dict()
        for key in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range"):
            rows.append((f"V.{key}", _num(v[key]), _num(v.get(f"U_{key}")), "um"))
    rows.extend(_optics_rows(ev.optics))
    square = (ev.model_indices or {}).get("squareness")
    if square:
        for name, e in square.items():
            rows.append((name, _num(e["value_urad"]), _num(e["U_urad"]), "urad"))
    elif model is not None:
        from volcal.model.names import SQUARENESS_NAMES

        for i, name in enumerate(SQUARENESS_NAMES):
            # + 0.0: a -0.0 (a squareness the tests do not see) is stored by SQLite as 0.0,
            # and a hash over -0.0 would then not match the record read back
            rows.append((name, float(model.errors.squareness[i]) + 0.0,
                         2.0 * float(model.squareness_std[i]), "urad"))
    # one row per name: the first wins (an axis name repeats a test's row)
    uniq: dict[str, tuple] = {}
    for r in rows:
        uniq.setdefault(r[0], r)
    return list(uniq.values())


def _optics_rows(optics: dict[str, Any] | None
                 ) -> list[tuple[str, float | None, float | None, str]]:
    """Rows of the direct optics' evaluation.

    :func:`volcal.standards.optics.evaluate_optics`, with ``U_<key>`` beside the values
    given a budget.
    """
    if not optics:
        return []
    rows: list[tuple[str, float | None, float | None, str]] = []
    for mid, line in (optics.get("straightness") or {}).items():
        for ref, tail in (("least_squares", ""), ("end_point", "_end_point")):
            e = line.get(ref) or {}
            rows.append((f"{mid}.straightness{tail}", _num(e.get("straightness_um")),
                         _num(e.get("U_straightness_um")), "um"))
            rows.append((f"{mid}.slope{tail}", _num(e.get("slope_urad")),
                         _num(e.get("U_slope_urad")), "urad"))
    for mid, e in (optics.get("angular") or {}).items():
        rows.append((f"{mid}.angular_deviation", _num(e.get("angular_deviation_urad")),
                     _num(e.get("U_angular_deviation_urad")), "urad"))
    for pair in optics.get("squareness") or []:
        name = pair["name"]
        for ref, tail in (("least_squares", ""), ("end_point", "_end_point")):
            e = pair.get(ref) or {}
            rows.append((f"optics.{name}{tail}", _num(e.get(name)),
                         _num(e.get(f"U_{name}")), "urad"))
    return rows


def _content_digest(session_sha256: str, models: list[tuple[str, str, bytes]]) -> str:
    """sha256 of the readings (the session's digest) and the model's files.

    Two adds of the same session and model have the same digest: the second returns the
    first record (:meth:`volcal.history.store.Store.append`).
    """
    h = hashlib.sha256(session_sha256.encode())
    for part in sorted(role.encode() + b"\0" + hashlib.sha256(content).digest()
                       for role, _, content in models):  # the model's content, not its name
        h.update(b"\0" + part)
    return h.hexdigest()


def _once(session: list[tuple[str, str, bytes]], models: list[tuple[str, str, bytes]]
          ) -> list[tuple[str, str, bytes]]:
    """The record's files, each content stored once.

    A session folder holding its model (the documented layout ``S/model.json``,
    ``S/model.npz``) would store the model twice: a session file whose content is one of
    the model's files is left out (its digest stays in ``session_sha256``).
    """
    model_digests = {hashlib.sha256(c).digest() for _, _, c in models}
    return [f for f in session if hashlib.sha256(f[2]).digest() not in model_digests] + models


def certificate_file(certificate: str | Path) -> Path:
    """The ``certificate.json`` that ``--certificate`` names.

    Parameters
    ----------
    certificate : str or Path
        The folder ``volcal report --certificate`` wrote, or its ``certificate.json``.

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        There is no such file.
    """
    from volcal.errors import VolcalInputError

    path = Path(certificate)
    if path.is_dir():
        path = path / "certificate.json"
    if not path.is_file():
        raise VolcalInputError("no certificate.json: --certificate names the folder "
                               "`volcal report --certificate` wrote", path)
    return path


def certificate_number(certificate: str | Path | None, session: Any) -> str | None:
    """The number of the calibration certificate of a session (``records.report_id``).

    Parameters
    ----------
    certificate : str or Path, optional
        The folder ``volcal report --certificate`` wrote (its ``certificate.json``) or that
        file. The certificate must be of this session's readings (its as-found or as-left
        ``readings_sha256``). Without it: ``[calibration] report_id`` of the session, else
        None.
    session : Session
        The session stored.

    Raises
    ------
    VolcalInputError
        No ``certificate.json``, not a volcal certificate, a certificate of other readings.
    """
    import json

    from volcal.errors import VolcalInputError
    from volcal.session.provenance import readings_digest

    if certificate is None:
        given = (session.calibration or {}).get("report_id")
        return None if given in (None, "") else str(given).strip()
    path = certificate_file(certificate)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise VolcalInputError(f"not a readable certificate ({exc})", path) from None
    number = doc.get("report_id") if isinstance(doc, dict) else None
    if not isinstance(number, str) or not number.strip():
        raise VolcalInputError("no certificate number here (key report_id): not a volcal "
                               "certificate", path)
    results = doc.get("results") if isinstance(doc.get("results"), dict) else {}
    digests = [(results.get(k) or {}).get("readings_sha256") for k in ("as_found", "as_left")
               if isinstance(results.get(k), dict)]
    if readings_digest(session) not in digests:
        raise VolcalInputError(f"certificate {number.strip()} is of other readings than the "
                               f"session {session.path or session.name} "
                               "(results.as_found.readings_sha256)",
                               path)
    return number.strip()


def calibration_record(session_folder: str | Path, model_path: str | Path | None,
                       as_left_of: str | None = None, supersedes: str | None = None,
                       force: bool = False, certificate: str | Path | None = None,
                       budget: str | Path | None = None) -> tuple[NewRecord, Any]:
    """The record of one calibration, ready for :meth:`Store.append`.

    Parameters
    ----------
    session_folder : str or Path
        The session (with readings).
    model_path : str or Path or None
        The model identified from it (checked against the session's readings). None: no
        linear model (a calibration of rotary axes only, or one whose rotary tests alone
        are of interest): the session's evaluation is stored without the model's results
        (volumetric indices, squareness), ``payload.model`` is None and a note says so.
    as_left_of : str, optional
        Id of the as-found calibration this one was measured after (tables loaded).
    supersedes : str, optional
        Id of the calibration record this one corrects.
    force : bool
        Accept a model identified from other readings.
    certificate : str or Path, optional
        The certificate folder (or its ``certificate.json``) of this calibration: its number
        is stored (:func:`certificate_number`).
    budget : str or Path, optional
        Uncertainty budget (TOML) the session is evaluated with: the U of every ISO 230-2
        parameter, diagonal and direct-optics result is stored (:func:`results_of`); the
        file is stored with the record (role ``budget``).

    Returns
    -------
    record : NewRecord
    session : Session
    """
    from volcal.identify.modelfile import check_model_session, load_model
    from volcal.session.format import read_session

    folder = Path(session_folder)
    session = read_session(folder)
    model = None
    if model_path is not None:
        model_path = Path(model_path)
        model = load_model(model_path)
        # a record keeps the model whole: its binary part too (the U of the stored results)
        model.require_uncertainty("a calibration record", model_path)
        check_model_session(model, session, force=force)
    number = certificate_number(certificate, session)
    bud = None
    if budget is not None:
        from volcal.uncertainty.budget import read_budget

        bud = read_budget(budget)
    ident = session.identity.to_dict()
    kept = session_files(session.path or folder)
    models = [] if model_path is None else model_files(model_path)
    digest = hashlib.sha256()
    for _, name, content in kept:
        digest.update(name.encode() + b"\0" + hashlib.sha256(content).digest())
    content_sha256 = _content_digest(digest.hexdigest(), models)
    files = _once(kept, models)
    if budget is not None:
        files.append(("budget", Path(budget).name, Path(budget).read_bytes()))
    date, notes = session.calibration.get("date"), []
    if date is None:  # not given: the simulation's date, else the newest reading file's
        from volcal.session.identity import parse_date

        prov = session.provenance.get("date")
        if prov is not None:
            date, src = parse_date(prov), "the simulation's date ([provenance] date)"
        else:
            import datetime as _dt

            newest = max((folder / m.file).stat().st_mtime for m in session.measurements)
            date = _dt.datetime.fromtimestamp(newest, _dt.UTC).date().isoformat()
            src = "the date of the newest measurement file"
        notes.append(f"no [calibration] date in the session: dated {date}, {src}")
    if model is None:
        from volcal.session.kinds import kind_of

        present = {str(m.kind) for m in session.measurements}
        linear = any(kind_of(k).in_design for k in present)
        stored = (["the session's linear tests with their ISO 230-2 results only"] if linear
                  else [])
        if "rotary" in present:
            stored.append("the rotary tests' ISO 230-2 results (urad)")
        if present & {"probe_sphere", "r_test"}:
            stored.append("the rotary axes' location errors")
        notes.append("no model given: stored without a linear model (no identified error "
                     "functions, volumetric indices or squareness)"
                     + ("; stored: " + "; ".join(stored) if stored else ""))
    payload = {
        "machine": ident,
        "calibration": session.calibration,
        "session_sha256": digest.hexdigest(),
        "content_sha256": content_sha256,
        "measurements": [m.id for m in session.measurements],
        "kinds": sorted({str(m.kind) for m in session.measurements}),
        "unmeasured": session.unmeasured_ids,
        "warnings": list(session.warnings),
        "model": None if model is None or model_path is None else {
            "format": model.format, "file": model_path.name, "sigma_um": model.fit.sigma_um,
            "n_readings": model.fit.n_readings},
        "k": 2.0,
        "notes": notes,
    }
    if budget is not None:
        payload["budget"] = {"file": Path(budget).name,
                             "sha256": hashlib.sha256(Path(budget).read_bytes()).hexdigest()}
    rec = NewRecord("calibration", payload, date=date, as_left_of=as_left_of,
                    supersedes=supersedes, files=files, results=results_of(session, model, bud),
                    equipment=list(session.equipment), report_id=number)
    return rec, session
