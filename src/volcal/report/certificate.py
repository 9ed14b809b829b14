"""The calibration certificate: the record a laboratory signs (ISO/IEC 17025:2017, 7.8).

:func:`build_certificate` turns one measured session (the *as-found* state), optionally a
second one measured after compensation tables were loaded (the *as-left* state), into
one JSON-ready document of format ``volcal-certificate/1``
(``report/schemas/volcal-certificate-1.schema.json``, ``docs/certificate.md``). The
PDF (:mod:`volcal.report.certificate_pdf`), the HTML
(:mod:`volcal.report.certificate_html`) and ``certificate.json`` are views of that one
document, so they always carry the same content.

Where the fields come from:

* identity: ``[machine]``, ``[calibration]``, ``[[equipment]]`` of ``session.toml``
  (:mod:`volcal.session.identity`);
* results: :func:`volcal.standards.session.evaluate_session` (ISO 230-2 per linear test,
  ISO 230-6 per diagonal, ISO 230-1 volumetric indices of the identified model) and the
  direct optics' own ISO 230-1 evaluation (:mod:`volcal.report.certificate_optics`:
  straightness, angular deviation, squareness by optical square);
* measurement uncertainty: ``U_*`` keys (or attributes) of the results and per-measurement
  ``budget`` objects, when an uncertainty budget was evaluated; otherwise the certificate
  says that none was given;
* conformity: a tolerance (:class:`volcal.standards.tolerance.Tolerance`) and a decision
  rule (``simple`` or ``guarded``, ILAC-G8:09/2019; ISO 14253-1:2017);
* as-found / as-left: the two sessions' *measured* results side by side; the compensation
  tables loaded in between are named by their manifest (``volcal-compensation.toml``) and
  never applied again.

The certificate is issued when the session carries ``[calibration]`` keys or
``[[equipment]]`` (:func:`certificate_applies`), or on request.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
import re
from pathlib import Path
from typing import Any, NotRequired, TypedDict

from volcal.errors import VolcalInputError
from volcal.session.identity import (
    CALIBRATION_KEYS,
    MACHINE_KEYS,
    MachineIdentity,
    as_date,
    parse_date,
    same_machine,
)
from volcal.standards.decision import RULE_TEXT as _RULE_TEXT
from volcal.standards.decision import conformity_verdict

__all__ = ["CERTIFICATE_FORMAT", "END_MARK", "NOT_STATED", "TITLE", "build_certificate",
           "certificate_applies", "conformity_verdict", "content_sha256", "environment_of",
           "equipment_status", "refuse_expired", "report_id", "tables_of"]

CERTIFICATE_FORMAT = "volcal-certificate/1"
"""Format (and version) of ``certificate.json``."""
TITLE = "Calibration certificate"
"""Title of the document (ISO/IEC 17025:2017, 7.8.2.1 a)."""
END_MARK = "End of certificate"
"""Printed after the last line of the certificate (7.8.2.1 g: the end is recognisable)."""

ENVIRONMENT_KEYS: tuple[tuple[str, str, str], ...] = (
    ("air_temperature_c", "air temperature", "°C"),
    ("air_pressure_pa", "air pressure", "Pa"),
    ("humidity_pct", "relative humidity", "%"),
    ("material_temperature_c", "material temperature", "°C"),
)
"""Environment quantities a session records: key (CSV column and ``environment`` table
key), name, unit."""

_POSITIONING_KEYS = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up",
                     "R_down", "B", "B_mean")

METHODS: dict[str, dict[str, str]] = {
    "ISO 230-2": {"title": "Test code for machine tools, part 2: determination of accuracy "
                  "and repeatability of positioning of numerically controlled axes",
                  "reference": "ISO 230-2"},
    "ISO 230-6": {"title": "Test code for machine tools, part 6: determination of "
                  "positioning accuracy on body and face diagonals (diagonal displacement "
                  "tests)", "reference": "ISO 230-6"},
    "ISO 230-1": {"title": "Test code for machine tools, part 1: geometric accuracy of "
                  "machines operating under no-load or quasi-static conditions "
                  "(volumetric indices, annex)", "reference": "ISO 230-1"},
    "ISO 230-1 direct optics": {
        "title": "Test code for machine tools, part 1: geometric accuracy of machines "
        "operating under no-load or quasi-static conditions (straightness about the "
        "least-squares reference line, angular deviation, squareness by optical square; "
        "each optic evaluated on its own)", "reference": "ISO 230-1"},
    "volcal identification": {
        "title": "Identification of the 21 rigid-body error functions and squareness "
        "errors of the machine from all laser readings (Bayesian least squares on the "
        "kinematic chain)", "reference": "volcal docs/identification.md"},
    "ISO 230-1 location errors": {
        "title": "Location errors of the rotary axes (ISO 230-1:2012 3.5) identified from the "
        "centre of a calibration sphere probed at rotary poses, or its displacement read by "
        "three sensors on the spindle (R-test), with the sphere centre's deviation per path "
        "(ISO 10791-6-style)", "reference": "volcal docs/fiveaxis.md"},
    "refractive index of air": {
        "title": "Readings referred to air and 20 °C from the measured environment (Ciddor "
        "1996 or modified Edlén, Birch & Downs 1993/1994; ISO 1)",
        "reference": "volcal docs/environment.md"},
}
"""The methods a certificate may name, with their references."""


# --------------------------------------------------------------------------- identity


def certificate_applies(session: Any) -> bool:
    """Whether a session carries what makes its report a certificate.

    Parameters
    ----------
    session : Session
        A session read by :func:`volcal.session.format.read_session`.

    Returns
    -------
    bool
        True when ``[calibration]`` holds one of its keys (date, operator, customer,
        laboratory) or the session lists ``[[equipment]]``. The machine's identity keys
        alone (used by the compensation manifest and the history) do not.
    """
    cal = getattr(session, "calibration", {}) or {}
    return any(k in cal for k in CALIBRATION_KEYS) or bool(getattr(session, "equipment", []))


def _measurement_date(session: Any) -> str | None:
    return (getattr(session, "calibration", {}) or {}).get("date")


def readings_sha256(session: Any) -> str:
    """SHA-256 of the session's readings (:func:`volcal.session.provenance.readings_digest`).

    Parameters
    ----------
    session : Session
        The session.

    Returns
    -------
    str
        64 hex digits.
    """
    from volcal.session.provenance import readings_digest

    return readings_digest(session)


def _lab_code(laboratory: str | None) -> str:
    words = re.findall(r"[A-Za-z0-9]+", laboratory or "")
    code = "".join(w[0] for w in words).upper()[:6]
    return code or "VOLCAL"


NOT_STATED = ("report_id", "report_id_source", "content_sha256", "issued", "generator")
"""Top-level keys of the certificate left out of :func:`content_sha256`: the number
itself, and when and by which program version it was written (``dates.issued`` too)."""

_DIGITS = 9
"""Significant digits of every number in :func:`content_sha256`."""

_MODEL_NUMBERS = ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range", "U_um", "k")
"""Keys of ``results.*.volumetric`` computed from the model: they enter
:func:`content_sha256` through ``model_sha256`` (and ``systematic_included``)."""


def _canonical(x: Any) -> Any:
    """Numbers to :data:`_DIGITS` significant digits, for a digest of what is stated."""
    if isinstance(x, dict):
        return {str(k): _canonical(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_canonical(v) for v in x]
    if isinstance(x, float):
        return float(f"{x:.{_DIGITS}g}")
    return x


def _stated(doc: dict[str, Any]) -> dict[str, Any]:
    """What :func:`content_sha256` digests.

    The document without :data:`NOT_STATED`, the model's numbers replaced by its digest.
    """
    import copy

    body = copy.deepcopy({k: v for k, v in doc.items() if k not in NOT_STATED})
    if isinstance(body.get("dates"), dict):
        body["dates"].pop("issued", None)
    for res in (body.get("results") or {}).values():
        if not isinstance(res, dict):
            continue
        vol = res.get("volumetric")
        if isinstance(vol, dict) and vol.get("model_sha256"):
            for k in _MODEL_NUMBERS:
                vol.pop(k, None)
        if res.get("elv_source") == "model":
            res.pop("elv", None)
    for row in (body.get("conformity") or {}).get("statements") or []:
        if str(row.get("quantity", "")).startswith("volumetric"):
            row.pop("value_um", None)
            row.pop("U_um", None)
    return body


def content_sha256(doc: dict[str, Any]) -> str:
    """SHA-256 of everything a certificate states (the source of its derived number).

    Every field of the document enters (identity, methods, environment, equipment,
    results with the readings' digests, the model's digest, the uncertainty statement
    and budget tables, the specification, decision rule and guard band of the statement
    of conformity, the as-left results and the tables, the remarks) except
    :data:`NOT_STATED` and ``dates.issued``. The numbers computed from the identified
    model (volumetric indices, their U, the volumetric statement's value and U, a
    model's ELv) enter through what they are computed from: ``model_sha256`` (the model's
    values at the 7 digits of its file) and ``systematic_included``, so that a model
    in memory and the same model read back from its file give the same number. Other
    numbers with :data:`_DIGITS` significant digits; canonical JSON (sorted keys, no
    spaces).

    Parameters
    ----------
    doc : dict
        A certificate (``volcal-certificate/1``), with or without its number.

    Returns
    -------
    str
        64 hex digits.
    """
    import json

    text = json.dumps(_canonical(_stated(doc)), sort_keys=True, separators=(",", ":"),
                      ensure_ascii=False, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def report_id(session: Any, as_left: Any = None, issued: str | None = None,
              content: str | None = None) -> tuple[str, str]:
    """The unique identification of the certificate (ISO/IEC 17025:2017, 7.8.2.1 c).

    Parameters
    ----------
    session : Session
        The as-found session.
    as_left : Session, optional
        The as-left session.
    issued : str, optional
        Date of issue (ISO 8601), used when the session has no date of measurement.
    content : str, optional
        :func:`content_sha256` of the certificate (:func:`build_certificate` gives it):
        the number's digits come from it. Without it, from the readings alone.

    Returns
    -------
    report_id : str
        ``[calibration] report_id`` when given; otherwise
        ``<laboratory initials>-<YYYYMMDD of measurement>-<8 hex digits>``, the digits
        the start of ``content`` (everything the certificate states): the same content
        gives the same number, a re-issue with other content (a budget, a tolerance,
        another decision rule or model, an as-left session) another. Without
        ``content``, the start of the SHA-256 of the readings' digests (as-found, then
        as-left).
    source : str
        ``'calibration.report_id'`` or ``'derived'``.
    """
    cal = session.calibration or {}
    given = cal.get("report_id")
    if given is not None:
        if not isinstance(given, str | int) or not str(given).strip():
            raise VolcalInputError(f"expected text, got {given!r}",
                                   _toml(session), None, "calibration.report_id")
        return str(given).strip(), "calibration.report_id"
    if content is not None:
        digits = content[:8]
    else:
        h = hashlib.sha256(readings_sha256(session).encode())
        if as_left is not None:
            h.update(readings_sha256(as_left).encode())
        digits = h.hexdigest()[:8]
    day = _measurement_date(session) or issued or _dt.date.today().isoformat()
    return (f"{_lab_code(cal.get('laboratory'))}-{as_date(day):%Y%m%d}-"
            f"{digits.upper()}", "derived")


def _toml(session: Any) -> Path | None:
    return None if session.path is None else Path(session.path) / "session.toml"


def _text(cal: dict[str, Any], key: str, session: Any) -> str | None:
    v = cal.get(key)
    if v is None:
        return None
    if isinstance(v, str | int) and not isinstance(v, bool):
        return str(v)
    raise VolcalInputError(f"expected text, got {v!r}", _toml(session), None,
                           f"calibration.{key}")


# --------------------------------------------------------------------------- equipment


def equipment_status(sessions: dict[str, Any]) -> list[dict[str, Any]]:
    """Every instrument of the sessions, each once, with whether it was out of date.

    Parameters
    ----------
    sessions : dict of str to Session
        ``{'as_found': S1, 'as_left': S2}`` (as-left optional).

    Returns
    -------
    list of dict
        The ``[[equipment]]`` entries (keys of :data:`volcal.session.identity.EQUIPMENT_KEYS`
        present), plus ``used_in`` (the states it measured), ``expired`` (its ``due``
        date lies before a date of measurement it was used on) and ``expired_on`` (those
        dates). Entries are the same instrument when role, make, model, serial and
        certificate agree.
    """
    out: dict[tuple, dict[str, Any]] = {}
    for state, s in sessions.items():
        day = _measurement_date(s)
        for e in s.equipment:
            key = tuple(e.get(k) for k in ("role", "make", "model", "serial", "certificate"))
            item = out.setdefault(key, {**{k: v for k, v in e.items()}, "used_in": [],
                                        "expired": False, "expired_on": []})
            item["used_in"].append(state)
            on = day or _dt.date.today().isoformat()
            if "due" in e and as_date(e["due"]) < as_date(on):
                item["expired"] = True
                item["expired_on"].append(on[:10])
    return list(out.values())


def describe_item(e: dict[str, Any], due: bool = True) -> str:
    """One line naming an equipment item: role, make model, serial, certificate (, due).

    Parameters
    ----------
    e : dict
        An ``[[equipment]]`` entry.
    due : bool
        Append the due date.

    Returns
    -------
    str
    """
    name = " ".join(str(e[k]) for k in ("make", "model") if e.get(k))
    parts = [e.get("role", "?") + (f" {name}" if name else "")]
    if e.get("serial"):
        parts.append(f"serial {e['serial']}")
    if e.get("certificate"):
        parts.append(f"certificate {e['certificate']}")
    if due and e.get("due"):
        parts.append(f"due {e['due']}")
    return ", ".join(parts)


def refuse_expired(sessions: dict[str, Any]) -> None:
    """``--strict``: refuse a certificate made with an instrument out of calibration.

    Parameters
    ----------
    sessions : dict of str to Session
        ``{'as_found': S1, 'as_left': S2}``.

    Raises
    ------
    VolcalInputError
        Naming ``session.toml``, the ``equipment[i]`` entry, the item (role, make, model,
        serial, certificate) and its due date against the date of measurement.
    """
    for state, s in sessions.items():
        day = _measurement_date(s) or _dt.date.today().isoformat()
        for i, e in enumerate(s.equipment, start=1):
            if "due" in e and as_date(e["due"]) < as_date(day):
                raise VolcalInputError(
                    f"--strict: equipment item {describe_item(e, due=False)} was due for "
                    f"calibration on {e['due']}, before the date of measurement {day[:10]} "
                    f"({state.replace('_', '-')}); no certificate is issued with expired "
                    "equipment (recalibrate it, or drop --strict to issue the certificate "
                    "with the item flagged)", _toml(s), None, f"equipment[{i}].due")


# --------------------------------------------------------------------------- environment


class EnvironmentStats(TypedDict):
    """One recorded quantity of a measurement (:func:`environment_of`)."""

    min: float
    max: float
    mean: float
    n: int
    source: NotRequired[str]  # 'readings' or 'environment table'


def _stats(values: Any) -> EnvironmentStats | None:
    import numpy as np

    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    return {"min": float(v.min()), "max": float(v.max()), "mean": float(v.mean()),
            "n": int(v.size)}


def environment_of(session: Any) -> dict[str, Any]:
    """The environment as measured during a session.

    Parameters
    ----------
    session : Session
        The session: per measurement, the CSV columns ``air_temperature_c``,
        ``air_pressure_pa``, ``humidity_pct``, ``material_temperature_c`` (row by row)
        or the keys of its ``environment`` table (``docs/environment.md``).

    Returns
    -------
    dict
        ``measurements``: one entry per measurement with its recorded quantities, each
        ``{min, max, mean, n, source}`` (source ``'readings'`` for a CSV column,
        ``'environment table'`` for a single value), plus ``material`` /
        ``expansion_ppm_per_k`` when stated, and for laser length measurements
        ``readings``: ``compensated_by`` (``'laser software'`` or ``'volcal (raw
        readings)'``), ``referred_by`` (``'laser software'``, ``'volcal'``, ``'not
        stated'``) with the ``material_temperature_c`` [degC] and
        ``expansion_ppm_per_k`` [ppm/K] volcal applied; ``summary``: per quantity the range over
        the session; ``recorded``: whether anything was recorded.
    """
    rows = []
    summary: dict[str, dict[str, float]] = {}
    for m in session.measurements:
        env = m.meta.get("environment") or {}
        entry: dict[str, Any] = {"measurement": m.id}
        for key, _name, _unit in ENVIRONMENT_KEYS:
            st: EnvironmentStats | None = None
            if key in m.columns:
                st = _stats(m.columns[key])
                if st is not None:
                    st["source"] = "readings"
            if st is None and isinstance(env.get(key), int | float) \
                    and not isinstance(env.get(key), bool) and math.isfinite(env[key]):
                x = float(env[key])
                st = {"min": x, "max": x, "mean": x, "n": 1, "source": "environment table"}
            if st is None:
                continue
            entry[key] = st
            acc = summary.setdefault(key, {"min": st["min"], "max": st["max"]})
            acc["min"] = min(acc["min"], st["min"])
            acc["max"] = max(acc["max"], st["max"])
        for k in ("material", "expansion_ppm_per_k"):
            if k in env:
                entry[k] = env[k]
        from volcal.environment.apply import thermal_record
        from volcal.session.kinds import kind_of

        if kind_of(m.kind).raw_readings:  # laser lengths
            rec = thermal_record(m)  # how the readings were compensated and referred
            entry["readings"] = {k: rec[k] for k in ("compensated_by", "referred_by",
                                                     "material_temperature_c",
                                                     "expansion_ppm_per_k")}
        if len(entry) > 1:
            rows.append(entry)
    return {"recorded": bool(summary), "summary": summary, "measurements": rows}


# --------------------------------------------------------------------------- tables


def tables_of(folder: str | Path, session: Any) -> dict[str, Any]:
    """The compensation tables loaded between as-found and as-left, named by their manifest.

    The tables are only *named*: the as-left session was measured with them active, so
    applying them again would count them twice.

    Parameters
    ----------
    folder : str or Path
        Folder written by ``volcal compensate`` (with ``volcal-compensation.toml``).
    session : Session
        The as-found session (the manifest's machine must be the same machine).

    Returns
    -------
    dict
        ``folder`` (its name), ``manifest`` (file name), ``manifest_sha256``, ``format``,
        ``controller_format``, ``model``, ``model_sha256`` (when recorded), ``carries``,
        ``files`` and ``machine`` (the identity the manifest records).

    Raises
    ------
    VolcalInputError
        No manifest, damaged TOML, or tables of another machine.
    """
    from volcal.compensate.formats import MANIFEST
    from volcal.report.pipeline import read_manifest

    folder = Path(folder)
    man = read_manifest(folder)
    path = folder / MANIFEST
    out: dict[str, Any] = {"folder": folder.resolve().name, "manifest": MANIFEST,
                           "manifest_sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
    for k in ("format", "controller_format", "model", "model_sha256", "sign", "spacing_mm"):
        if k in man:
            out[k] = man[k]
    out["carries"] = [str(c) for c in man.get("carries", [])]
    out["files"] = [str(f) for f in man.get("files", [])]
    mach = man.get("machine")
    if isinstance(mach, dict):
        ident = MachineIdentity.from_dict(mach)
        same, why = same_machine(ident, session.identity)
        out["machine"] = ident.to_dict()
    else:  # volcal-compensation/1: the machine's name only
        ident = None
        name = None if mach is None else str(mach)
        same, why = (name is None or name == session.name), \
            f"name {name!r} is not {session.name!r}"
        out["machine"] = {"name": name} if name else {}
    if not same:
        raise VolcalInputError(f"--tables: these tables are for another machine ({why})",
                               path, None, "machine")
    return out


# --------------------------------------------------------------------------- conformity


RULE_TEXT = _RULE_TEXT
"""The decision rules as stated on the certificate: :data:`volcal.standards.decision.
RULE_TEXT` (one wording for every output)."""


def _U(result: Any, key: str) -> float | None:
    """An expanded uncertainty ``U_<key>`` carried by a result (attribute or dict key)."""
    name = f"U_{key}"
    v = result.get(name) if isinstance(result, dict) else getattr(result, name, None)
    try:
        return None if v is None or not math.isfinite(float(v)) else float(v)
    except (TypeError, ValueError):
        return None


def _as_dict(x: Any) -> Any:
    if isinstance(x, dict):
        return x
    if hasattr(x, "to_dict"):
        return x.to_dict()
    return {}


# --------------------------------------------------------------------------- results


def _positioning(ev: Any, unc: dict[str, Any]) -> list[dict[str, Any]]:
    out = []
    for mid, r in ev.iso230_2.items():
        d = {**_as_dict(r), **{k: v for k in dir(r) if k.startswith("U_")
                               and isinstance(v := getattr(r, k, None), int | float)},
             **_as_dict(unc.get(mid, {}))}
        row: dict[str, Any] = {"measurement": mid, "axis": ev.axis.get(mid, "?"),
                               "edition": d.get("edition", getattr(r, "edition", None)),
                               "complete": bool(d.get("complete", True)),
                               "n_runs_up": d.get("n_runs_up"),
                               "n_runs_down": d.get("n_runs_down"),
                               "targets": len(d.get("targets", []))}
        row["values_um"] = {k: float(d[k]) for k in _POSITIONING_KEYS if k in d}
        U = {k: u for k in _POSITIONING_KEYS if (u := _U(d, k)) is not None}
        row["U_um"] = U or None
        if U and d.get("k") is not None:
            row["k"] = float(d["k"])
        out.append(row)
    return out


def _rotary(ev: Any) -> list[dict[str, Any]]:
    """The rotary axes' ISO 230-2 parameters [urad] with U and the closure."""
    out = []
    for mid, r in (getattr(ev, "rotary", None) or {}).items():
        d = r.to_dict("urad")
        row: dict[str, Any] = {"measurement": mid, "axis": r.axis, "edition": d["edition"],
                               "complete": bool(d["complete"]),
                               "n_runs_up": d.get("n_runs_up"),
                               "n_runs_down": d.get("n_runs_down"),
                               "targets": len(d["targets"]), "unit": "urad",
                               "values": {k: float(d[k]) for k in _POSITIONING_KEYS if k in d},
                               "U": ({k: float(d[f"U_{k}"]) for k in _POSITIONING_KEYS
                                      if f"U_{k}" in d} or None),
                               "closure": d["closure"] or None}
        if d.get("k") is not None:
            row["k"] = float(d["k"])
        out.append(row)
    return out


def _diagonals(ev: Any, unc: dict[str, Any]) -> list[dict[str, Any]]:
    out = []
    for mid, r in ev.iso230_6.items():
        d = {**_as_dict(r), **{k: v for k in dir(r) if k.startswith("U_")
                               and isinstance(v := getattr(r, k, None), int | float)},
             **_as_dict(unc.get(mid, {}))}
        row = {"measurement": mid, "diagonal": d.get("diagonal"),
               "length_mm": float(d["length_mm"]), "E_D_um": float(d["E_D"]),
               "complete": bool(d.get("complete", True)),
               "points": f"{d.get('points_measured')} of {d.get('points_planned')}",
               "U_E_D_um": _U(d, "E_D")}
        out.append(row)
    return out


def _systematic_statement(volumetric: Any) -> dict[str, Any]:
    """Whether the volumetric U includes the model's systematic part.

    In the words of ``volcal evaluate session --model``
    (:func:`volcal.standards.model_uncertainty.model_uncertainty` notes).
    """
    u = getattr(volumetric, "uncertainty", None)
    if u is None:
        return {}
    included = bool(getattr(u, "systematic", False))
    notes = [n for n in getattr(u, "notes", []) if "systematic part" in n]
    return {"systematic_included": included,
            "uncertainty_note": notes[0] if notes else (
                "the model's systematic part is included" if included else
                "the model carries no systematic part: U is the identification's noise "
                "and prior part only")}


def _results(session: Any, ev: Any, with_model: bool, unc: dict[str, Any] | None = None,
             optics_budget: Any = None, model_digest: str | None = None) -> dict[str, Any]:
    from volcal.report.certificate_optics import direct_optics

    unc = unc or {}
    vol: dict[str, Any] | None = None
    if ev.volumetric is not None:
        v = _as_dict(ev.volumetric)
        vol = {k: float(v[k]) for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range")
               if k in v}
        vol["n"] = int(v.get("n", 0))
        vol["source"] = "identified model (volcal identification)"
        U = {k: float(v[f"U_{k}"]) for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ",
                                              "E_VXYZ_range") if v.get(f"U_{k}") is not None}
        if U:  # from the model's covariance (volcal.standards.model_uncertainty)
            vol["U_um"] = U
            vol["k"] = float(v.get("k_volumetric", 2.0))
            vol.update(_systematic_statement(ev.volumetric))
        if model_digest is not None:
            vol["model_sha256"] = model_digest
    if getattr(ev, "optics_evaluated", False) and getattr(ev, "budget", None) is optics_budget:
        optics = None if ev.optics is None else direct_optics(session, optics_budget, ev.optics)
    else:  # an evaluation without the optics, or of another budget
        optics = direct_optics(session, optics_budget)
    return {"session": session.name if session.path is None else Path(session.path).name,
            "date": _measurement_date(session),
            "readings": sum(m.n for m in session.measurements),
            "readings_sha256": readings_sha256(session),
            "simulated": (session.provenance or {}).get("readings") == "simulated",
            "positioning": _positioning(ev, unc), "diagonals": _diagonals(ev, unc),
            "volumetric": vol if with_model else None,
            "elv": ev.elv, "elv_source": ev.elv_source or None,
            "skipped": dict(ev.skipped),
            "direct_optics": optics,
            **({"rotary": _rotary(ev)} if getattr(ev, "rotary", None) else {})}


def _pairs(found: dict[str, Any], left: dict[str, Any]) -> list[dict[str, Any]]:
    """Pair the as-found and as-left results measurement by measurement."""
    rows = []
    lp = {r["measurement"]: r for r in left["positioning"]}
    for r in found["positioning"]:
        o = lp.get(r["measurement"])
        if o is None:
            continue
        for k in ("A", "E", "M", "R", "B"):
            if k in r["values_um"] and k in o["values_um"]:
                rows.append({"measurement": r["measurement"], "axis": r["axis"],
                             "quantity": k, "as_found_um": r["values_um"][k],
                             "as_left_um": o["values_um"][k]})
    ld = {r["measurement"]: r for r in left["diagonals"]}
    for r in found["diagonals"]:
        o = ld.get(r["measurement"])
        if o is not None:
            rows.append({"measurement": r["measurement"], "axis": r["diagonal"],
                         "quantity": "E_D", "as_found_um": r["E_D_um"],
                         "as_left_um": o["E_D_um"]})
    return rows


def _rotary_pairs(found: dict[str, Any], left: dict[str, Any]) -> list[dict[str, Any]]:
    """Pair the as-found and as-left rotary tests axis by axis [urad].

    A rotary test of the as-found session pairs with the as-left test of the same axis:
    the one of the same measurement id, or else the only one of that axis when each
    session has one test of it (several tests of one axis under other ids are ambiguous:
    not paired).

    Parameters
    ----------
    found, left : dict
        :func:`_results` of the two sessions.

    Returns
    -------
    list of dict
        ``measurement`` (the as-found id), ``as_left_measurement`` (the as-left id),
        ``axis``, ``quantity`` (``A``, ``E``, ``M``, ``R``, ``B``), ``as_found_urad``,
        ``as_left_urad``.
    """
    rows: list[dict[str, Any]] = []
    fr, lr = found.get("rotary") or [], left.get("rotary") or []
    for r in fr:
        same_axis = [o for o in lr if o["axis"] == r["axis"]]
        o = next((o for o in same_axis if o["measurement"] == r["measurement"]), None)
        if o is None and len(same_axis) == 1 and sum(x["axis"] == r["axis"] for x in fr) == 1:
            o = same_axis[0]
        if o is None:
            continue
        for k in ("A", "E", "M", "R", "B"):
            if k in r["values"] and k in o["values"]:
                rows.append({"measurement": r["measurement"],
                             "as_left_measurement": o["measurement"], "axis": r["axis"],
                             "quantity": k, "as_found_urad": r["values"][k],
                             "as_left_urad": o["values"][k]})
    return rows


NO_SYSTEMATIC_VERDICT = ("qualified: its U is the identification's noise and prior part "
                         "only (the model carries no systematic part: laser, air and "
                         "material inputs not included; identify with --budget to include "
                         "them)")
"""Appended to the note of a volumetric statement whose U lacks the systematic part."""


def _conformity(tolerance: Any, results: dict[str, dict[str, Any] | None], rule: str,
                guard_band_um: float | None,
                volumetric_before: tuple[float | None, float | None] | None
                ) -> dict[str, Any] | None:
    if tolerance is None:
        return None
    rows = []
    for state, res in results.items():
        if res is None:
            continue
        limits = [(axis, "A", T) for axis, T in tolerance.axis_um.items()]
        limits += [(axis, key, T) for axis, d in (getattr(tolerance, "parameters", None)
                                                  or {}).items() for key, T in d.items()]
        for axis, key, T in limits:
            tests = [r for r in res["positioning"] if r["axis"] == axis
                     and key in r["values_um"]]
            if not tests:
                rows.append({"state": state, "quantity": f"{axis}: ISO 230-2 {key}",
                             "tolerance_um": T, "value_um": None, "U_um": None,
                             "verdict": None, "note": f"no linear test of {axis}"})
                continue
            worst = max(tests, key=lambda r: r["values_um"][key])
            U = (worst["U_um"] or {}).get(key)
            value = worst["values_um"][key]
            verdict, note = conformity_verdict(value, T, rule, U, guard_band_um)
            rows.append({"state": state, "quantity": f"{axis}: ISO 230-2 {key} "
                         f"(largest of {len(tests)} tests, {worst['measurement']})",
                         "tolerance_um": T, "value_um": value, "U_um": U,
                         "verdict": verdict, "note": note})
        if tolerance.volumetric_um is not None:
            T = tolerance.volumetric_um
            value, U = (volumetric_before if state == "as_found" and volumetric_before
                        else (None, None))
            if value is None:
                rows.append({"state": state, "quantity": "volumetric |e|",
                             "tolerance_um": T, "value_um": None, "U_um": None,
                             "verdict": None,
                             "note": "needs the identified model of this session"})
            else:
                verdict, note = conformity_verdict(value, T, rule, U, guard_band_um)
                vol = res.get("volumetric") or {}
                if vol.get("systematic_included") is False:
                    note = "; ".join(x for x in (note, NO_SYSTEMATIC_VERDICT) if x)
                rows.append({"state": state, "quantity": "volumetric |e| (largest over "
                             "the work zone, identified model)", "tolerance_um": T,
                             "value_um": value, "U_um": U, "verdict": verdict,
                             "note": note})
    from volcal.report.certificate_optics import optics_conformity

    um, urad = optics_conformity(tolerance, results, rule, guard_band_um)
    out = {"decision_rule": rule, "rule": RULE_TEXT[rule], "guard_band_um": guard_band_um,
           "tolerance": tolerance.text(), "statements": rows + um}
    if urad:
        out["statements_urad"] = urad
    return out


def _budgets(budgets: dict[str, Any] | None) -> dict[str, Any] | None:
    if not budgets:
        return None
    out = {}
    for mid, b in budgets.items():
        d = _as_dict(b)
        if not isinstance(d, dict):
            continue
        out[str(mid)] = _jsonable(d)
    return out or None


def _jsonable(x: Any) -> Any:
    import numpy as np

    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if x is None or isinstance(x, str | int | float | bool):
        return x
    return str(x)


def _methods(found: dict[str, Any], left: dict[str, Any] | None, sessions: dict[str, Any],
             with_model: bool) -> list[dict[str, Any]]:
    res = [found] + ([left] if left else [])
    # ISO 230-2 applies "equally to linear and rotary axes": the rotary tests are its too
    lin = sorted({r["measurement"] for x in res for r in [*x["positioning"],
                                                         *(x.get("rotary") or [])]})
    dia = sorted({r["measurement"] for x in res for r in x["diagonals"]})
    editions = sorted({str(r["edition"]) for x in res for r in [*x["positioning"],
                                                               *(x.get("rotary") or [])]
                       if r.get("edition")})
    out = []
    if lin:
        ed = ", ".join(editions) or None
        out.append({"id": "ISO 230-2", **METHODS["ISO 230-2"], "edition": ed,
                    "measurements": lin})
        if ed:
            out[-1]["reference"] = "ISO 230-2:" + "/".join(editions)
    if dia:
        out.append({"id": "ISO 230-6", **METHODS["ISO 230-6"], "edition": "2002",
                    "measurements": dia})
        out[-1]["reference"] = "ISO 230-6:2002"
    opt = sorted({r["measurement"] for x in res for k in ("straightness", "angular")
                  for r in (x.get("direct_optics") or {}).get(k, [])})
    if opt:
        out.append({"id": "ISO 230-1 direct optics", **METHODS["ISO 230-1 direct optics"],
                    "edition": "2012", "measurements": opt})
        out[-1]["reference"] = "ISO 230-1:2012"
    if with_model:
        out.append({"id": "volcal identification", **METHODS["volcal identification"],
                    "edition": None,
                    "measurements": [m.id for m in sessions["as_found"].measurements]})
        out.append({"id": "ISO 230-1", **METHODS["ISO 230-1"], "edition": "2012",
                    "measurements": []})
        out[-1]["reference"] = "ISO 230-1:2012"
    loc = sorted({mid for x in res for e in x.get("location") or []
                  for mid in e["measurements"]})
    if loc:
        out.append({"id": "ISO 230-1 location errors", **METHODS["ISO 230-1 location errors"],
                    "edition": "2012", "measurements": loc})
    raw = sorted({m.id for s in sessions.values() for m in s.measurements
                  if m.meta.get("readings") == "compensated"})
    if raw:
        out.append({"id": "refractive index of air", **METHODS["refractive index of air"],
                    "edition": None, "measurements": raw})
    return out


def build_certificate(session: Any, result: Any = None, *, as_left: Any = None,
                      tables: str | Path | None = None, tolerance: Any = None,
                      decision_rule: str | None = None, guard_band_um: float | None = None,
                      budgets: dict[str, Any] | None = None,
                      uncertainties: dict[str, Any] | None = None,
                      as_left_uncertainties: dict[str, Any] | None = None,
                      optics_budget: Any = None,
                      edition: str = "2014",
                      issued: str | None = None, generator: str | None = None,
                      technical_report: str | None = "report.pdf",
                      evaluation: Any = None,
                      as_left_evaluation: Any = None,
                      rotary_tolerance_urad: dict[str, float] | None = None,
                      location: list[Any] | None = None, location_tolerance: Any = None
                      ) -> dict[str, Any]:
    """Build the certificate document (``volcal-certificate/1``) of a calibration.

    Parameters
    ----------
    session : Session
        The as-found session (measured before any adjustment).
    result : IdentificationResult, optional
        Identified model of ``session`` (adds the ISO 230-1 volumetric indices and the
        volumetric conformity).
    as_left : Session, optional
        The session measured after the compensation tables were loaded. Its measured
        results are evaluated the same way and paired with the as-found ones; it must be
        the same machine.
    tables : str or Path, optional
        Compensation folder loaded between the two sessions, named by its manifest
        (:func:`tables_of`), never applied.
    tolerance : Tolerance, optional
        Per-axis ISO 230-2 ``A`` and/or volumetric tolerance [um] of the statement of
        conformity; its ``straightness_um`` [um] and ``squareness_urad`` [urad] limits,
        when given, are judged against the direct optics (``conformity.statements`` and
        ``conformity.statements_urad``).
    decision_rule : {'simple', 'guarded'}, optional
        Decision rule of the statement of conformity (:func:`conformity_verdict`);
        default the tolerance's ``rule`` attribute when it has one, else ``simple``.
    guard_band_um : float, optional
        Guard band of the guarded rule [um] (default the tolerance's
        ``guard_band_um``, else U).
    budgets : dict, optional
        Uncertainty budget per measurement id (a dict or an object with ``to_dict()``:
        ``measurand``, ``u_um``, ``dof``, ``k``, ``U_um`` and a list of ``components``
        or ``contributors``), printed as the budget tables.
    uncertainties, as_left_uncertainties : dict, optional
        Per measurement id of the as-found (as-left) session, an object with
        ``to_dict()`` (or a dict) holding ``U_<key>`` of the ISO 230-2 parameters (or
        ``U_E_D`` of a diagonal), ``k`` and optionally ``uncertainty.budget`` (its
        budget table). ``U_*`` attributes or keys of the results themselves are read as
        well.
    optics_budget : Budget, optional
        Uncertainty budget of the direct optics (``volcal report --budget``; its
        ``[optics]`` section, data-sheet defaults when absent): U and k of every
        straightness, angular deviation and squareness in ``results.*.direct_optics``
        (:func:`volcal.report.certificate_optics.direct_optics`), as ``volcal evaluate
        optics --budget``. Without it those U are null.
    edition : str
        ISO 230-2 edition of the evaluation.
    issued : str, optional
        Date of issue (ISO 8601); ``[calibration] issued`` or today when omitted.
    generator : str, optional
        Program that wrote the certificate (default ``volcal <version>``).
    technical_report : str, optional
        File name of the technical report issued with it (``report.pdf``), or None.
    evaluation, as_left_evaluation : SessionEvaluation, optional
        The one evaluation of each session (:func:`volcal.standards.session.
        evaluate_session`; the as-found one with ``result`` and, for a volumetric
        tolerance, ``work_zone_n``), as ``volcal report`` and
        :meth:`volcal.Calibration.report` give them: the certificate states their values
        and, when they were evaluated with a budget, their U (``uncertainties`` default to
        :attr:`~volcal.standards.session.SessionEvaluation.with_budget`). Evaluated here
        (without a budget) when omitted.
    rotary_tolerance_urad : dict of str to float, optional
        Tolerance of the accuracy A of each rotary axis (``{'C': 25.0}`` [urad]): the
        verdict of its rotary tests (simple rule), in ``results.rotary[*].verdict``.
    location : list of LocatedChain, optional
        The as-found session's location evaluation
        (:func:`volcal.identify.location_evaluation.locate_session`, with the model's
        linear errors), as the report step computes it; computed here when omitted. Its
        probe_sphere and r_test tests give ``results.<state>.location``
        (:func:`volcal.report.certificate_location.location_results`).
    location_tolerance : LocationTolerance, optional
        Tolerance and decision rule of the per-path sphere-centre test.

    Returns
    -------
    dict
        The certificate; validates against ``volcal-certificate-1.schema.json``.

    Raises
    ------
    VolcalInputError
        Sessions of two machines, tables of another machine, malformed identity keys.

    References
    ----------
    ISO/IEC 17025:2017, 7.8.2 (common requirements for reports), 7.8.4 (calibration
    certificates), 7.8.6 (statements of conformity). ILAC-G8:09/2019 (decision rules).
    """
    from volcal.standards.session import evaluate_session

    sessions = {"as_found": session}
    if as_left is not None:
        same, why = same_machine(session.identity, as_left.identity)
        if not same:
            raise VolcalInputError(f"--as-left: the sessions are of two machines ({why})",
                                   _toml(as_left), None, "machine")
        sessions["as_left"] = as_left
    cal = dict(session.calibration or {})
    warnings: list[str] = []
    if issued is None:
        issued = cal.get("issued")
    issued = parse_date(issued, _toml(session), "calibration.issued") if issued \
        else _dt.date.today().isoformat()
    if generator is None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            generator = f"volcal {version('volcal')}"
        except PackageNotFoundError:  # pragma: no cover - source checkout
            generator = "volcal"

    from volcal.standards.model_uncertainty import has_covariance

    ev = evaluation
    if ev is None:
        ev = evaluate_session(session, result, edition,
                              model_uncertainty=result is not None and has_covariance(result),
                              optics=True)
    if uncertainties is None:
        uncertainties = getattr(ev, "with_budget", None) or None
    model_digest = None
    if result is not None:
        from volcal.compensate.manifest import errors_digest

        model_digest = errors_digest(result.errors)
    found = _results(session, ev, result is not None, uncertainties, optics_budget,
                     model_digest)
    from volcal.identify.location_evaluation import locate_session
    from volcal.report.certificate_location import location_results

    if location is None:
        location = locate_session(session, result)
    if location:  # the probe_sphere and r_test tests' location errors (docs/fiveaxis.md)
        found["location"] = location_results(location, location_tolerance)
    for row in found.get("rotary", []):  # a rotary axis' A against its tolerance
        t = (rotary_tolerance_urad or {}).get(row["axis"])
        if t is not None:
            from volcal.standards.decision import decide

            row["tolerance"] = float(t)
            row["verdict"] = decide(row["values"]["A"], float(t), "simple").verdict
    left = None
    if as_left is not None:
        ev_left = as_left_evaluation
        if ev_left is None:
            ev_left = evaluate_session(as_left, None, edition, optics=True)
        if as_left_uncertainties is None:
            as_left_uncertainties = getattr(ev_left, "with_budget", None) or None
        left = _results(as_left, ev_left, False, as_left_uncertainties, optics_budget)
        left_location = locate_session(as_left)
        if left_location:
            left["location"] = location_results(left_location, location_tolerance)
    if decision_rule is None:
        decision_rule = getattr(tolerance, "rule", None) or "simple"
    if guard_band_um is None:
        guard_band_um = getattr(tolerance, "guard_band_um", None)
    budgets = dict(budgets or {})
    for state, unc in (("as-found", uncertainties), ("as-left", as_left_uncertainties)):
        for mid, u in (unc or {}).items():
            b = (_as_dict(u).get("uncertainty") or {}).get("budget")
            if isinstance(b, dict):
                budgets.setdefault(mid if state == "as-found" else f"{mid} (as-left)", b)

    vol_before = None
    if tolerance is not None and tolerance.volumetric_um is not None and result is not None:
        from volcal.standards.tolerance import Tolerance
        from volcal.standards.verdict import verdicts

        v = verdicts(Tolerance(tolerance.volumetric_um), ev, result.errors,
                     model=result if has_covariance(result) else None)[0]
        vol_before = (v.before_um, v.U_before_um)

    ident = session.identity.to_dict()
    for k in MACHINE_KEYS:
        if k not in ident:
            warnings.append(f"the item calibrated has no {k} ([machine] {k} in "
                            "session.toml)")
    lab = _text(cal, "laboratory", session)
    cust = _text(cal, "customer", session)
    for k, stated in (("laboratory", lab), ("customer", cust), ("date", cal.get("date")),
                      ("operator", cal.get("operator"))):
        if stated is None:
            warnings.append(f"not stated: [calibration] {k} in session.toml")
    equipment = equipment_status(sessions)
    for e in equipment:
        if e["expired"]:
            warnings.append(f"EXPIRED EQUIPMENT: {describe_item(e, due=False)} was due for "
                            f"calibration on {e['due']}, before the date of measurement "
                            f"{', '.join(e['expired_on'])}")
    if not equipment:
        warnings.append("no measuring equipment listed ([[equipment]] in session.toml)")
    env = {state: environment_of(s) for state, s in sessions.items()}
    for state, e in env.items():
        if not e["recorded"]:
            warnings.append(f"the {state.replace('_', '-')} session records no environment "
                            "(air and material temperature, pressure, humidity)")
    for state, s in sessions.items():
        if (s.provenance or {}).get("readings") == "simulated":
            warnings.append(f"the {state.replace('_', '-')} readings are simulated "
                            "(volcal simulate), not measured")
    if result is None and found.get("rotary"):  # a rotary-only calibration
        warnings.append("no linear model was identified (rotary tests only, each evaluated "
                        "on its own to ISO 230-2): no volumetric indices or error functions "
                        "of the linear axes")

    from volcal.report.certificate_optics import optics_budgets

    for x, suffix in ((found, ""), (left, " (as-left)")):
        if x and x["direct_optics"]:
            for k, b in optics_budgets(x["direct_optics"], suffix).items():
                budgets.setdefault(k, b)
            x["direct_optics"].pop("_budgets", None)
    budget = _budgets(budgets)
    has_U = any(r["U_um"] for x in (found, left) if x for r in x["positioning"]) or any(
        r["U_E_D_um"] is not None for x in (found, left) if x for r in x["diagonals"]) or any(
        (x["direct_optics"] or {}).get("uncertainty_evaluated") for x in (found, left) if x)
    if budget or has_U:
        corr = sorted({str(c["text"]).split("; correction at")[0]
                       for x in (uncertainties, as_left_uncertainties) for u in (x or {}).values()
                       if isinstance(c := _as_dict(u).get("corrections"), dict)
                       and c.get("text")})
        unc = {"given": True, "statement": "The expanded uncertainties U are stated at a "
               "coverage probability of about 95 % (coverage factor k from the effective "
               "degrees of freedom, JCGM 100:2008 G.4); the budget tables list every "
               "contributor." + "".join(f" {c[:1].upper()}{c[1:]}." for c in corr),
               "budgets": budget}
    else:
        unc = {"given": False, "statement": "No measurement-uncertainty budget given: the "
               "results are stated without their expanded uncertainty (ISO/IEC 17025:2017, "
               "7.8.4.1 requires it on a calibration certificate).", "budgets": None}
        warnings.append("no measurement-uncertainty budget given")

    from volcal.report.certificate_optics import optics_pairs

    results = {"as_found": found, "as_left": left}
    tab = None if tables is None else tables_of(tables, session)
    if tab is not None and as_left is None:
        warnings.append("--tables names the compensation loaded after the as-found "
                        "measurement, but no as-left session was given")
    doc: dict[str, Any] = {
        "format": CERTIFICATE_FORMAT,
        "title": TITLE,
        "report_id": "",
        "report_id_source": "derived",
        "content_sha256": "",
        "issued": issued,
        "generator": generator,
        "laboratory": {"name": lab, "address": _text(cal, "laboratory_address", session)},
        "customer": {"name": cust, "address": _text(cal, "customer_address", session)},
        "item": ident,
        "dates": {"as_found": found["date"], "as_left": left["date"] if left else None,
                  "issued": issued},
        "methods": _methods(found, left, sessions, result is not None),
        "environment": {"as_found": env["as_found"], "as_left": env.get("as_left")},
        "equipment": equipment,
        "results": results,
        "as_found_as_left": None if left is None else {
            "tables": tab, "pairs": _pairs(found, left),
            "direct_optics_pairs": optics_pairs(found["direct_optics"], left["direct_optics"]),
            **({"rotary_pairs": rp} if (rp := _rotary_pairs(found, left)) else {}),
            "statement": "As-found: measured before adjustment. As-left: measured after "
                         "the compensation tables below were loaded into the control. Both "
                         "are measured results; the tables are named, not applied again."},
        "tables": tab,
        "uncertainty": unc,
        "conformity": _conformity(tolerance, results, decision_rule, guard_band_um,
                                  vol_before),
        "signatures": {"performed_by": _text(cal, "operator", session),
                       "approved_by": _text(cal, "approved_by", session)},
        "technical_report": technical_report,
        "warnings": warnings,
        "end_mark": END_MARK,
    }
    doc = _jsonable(doc)
    # the number comes last: from everything stated above (or [calibration] report_id)
    doc["content_sha256"] = content_sha256(doc)
    doc["report_id"], doc["report_id_source"] = report_id(session, as_left, issued,
                                                          doc["content_sha256"])
    return doc
