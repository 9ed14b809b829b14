"""Model files: write and read them (``volcal-model/3``, ``/2``, ``/1``); check a model's session.

Format 3 (``docs/formats.md``, "Model file") is two files side by side:

* ``MODEL.json``: everything a person reads (functions and their standard uncertainties
  at the nodes, squareness, fit, identifiability, nuisances, outliers, the session's
  identity), a few hundred kB at most whatever the number of readings;
* ``MODEL.npz``: the large arrays, an uncompressed numpy ``.npz`` (a zip of ``.npy``
  members, fixed time stamps: the same model gives the same bytes): the covariance factor
  by part (``noise_factor``; the uncertainty issue adds ``systematic_factor``), the fitted
  value and the residual of every reading (``fitted_um``, ``residual_um``).

The JSON names the ``.npz`` (file name, in the JSON's folder) and its sha256. Writing is
atomic for both: the ``.npz`` first, then the JSON that records its digest, so a reader
never pairs a JSON with a binary part it was not written with. A JSON whose binary part
is missing or does not match its digest loads without uncertainty, with the reason
(:attr:`~volcal.identify.result.IdentificationResult.uncertainty_missing`, a
:class:`ModelFileWarning`); what needs the uncertainty then refuses it.
"""

from __future__ import annotations

import hashlib
import io
import json
import warnings
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import VolcalInputError
from volcal.identify.modelwrite import BINARY_SUFFIX, binary_path, write_model
from volcal.identify.result import MODEL_FORMAT, IdentificationResult
from volcal.io.sniff import is_model_file, model_path
from volcal.model.errorfunctions import MachineErrors

if TYPE_CHECKING:
    from volcal.session.format import Session

# write_model and binary_path live in volcal.identify.modelwrite (result.to_json calls the
# writer, which needs nothing of this module: no import cycle); re-exported here, where
# docs/formats.md documents them
__all__ = ["ModelFileWarning", "binary_path", "check_model_session", "load_model",
           "load_model_errors", "model_session_differences", "write_model"]


class ModelFileWarning(UserWarning):
    """A model file loaded with less than it should have (its binary part missing)."""


def _read_binary(path: Path, doc: dict[str, Any]) -> tuple[dict[str, np.ndarray] | None, str]:
    """The arrays of a format-3 model's binary part, or None and why not."""
    block = doc.get("arrays")
    if not isinstance(block, dict) or not isinstance(block.get("file"), str) \
            or not isinstance(block.get("sha256"), str):
        return None, "the JSON names no binary part ('arrays' with 'file' and 'sha256')"
    name = Path(block["file"]).name  # in the JSON's folder, never elsewhere
    bin_path = path.parent / name
    if not bin_path.is_file():
        return None, (f"its binary part {bin_path} is missing (copy it beside {path.name}, "
                      "or identify again)")
    data = bin_path.read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    size = block.get("bytes")
    if digest != block["sha256"] and isinstance(size, int) and len(data) != size:
        return None, (f"its binary part {bin_path} is truncated or damaged ({len(data)} "
                      f"bytes, the JSON records {size}: copy it again beside {path.name}, "
                      "or identify again)")
    if digest != block["sha256"]:
        return None, (f"its binary part {bin_path} does not match it (sha256 "
                      f"{digest[:12]}..., the JSON records {block['sha256'][:12]}...: written "
                      "by another identification; identify again)")
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
        return None, f"its binary part {bin_path} cannot be read ({exc})"
    members = block.get("members", {})
    if not isinstance(members, dict):
        return None, "the JSON's 'arrays.members' is not a table"
    for k, meta in members.items():
        a = arrays.get(k)
        shape = meta.get("shape") if isinstance(meta, dict) else None
        if a is None or not isinstance(shape, list) or list(a.shape) != shape:
            return None, (f"its binary part {bin_path} lacks the array {k!r} of the shape "
                          "the JSON names")
    for k, a in arrays.items():  # the digest matches: the values must still be numbers
        if a.dtype.kind not in "fiu":
            raise VolcalInputError(f"array {k!r} holds {a.dtype} values, not numbers",
                                   bin_path, None, k)
        bad = np.flatnonzero(~np.isfinite(a).reshape(-1))
        if bad.size:
            raise VolcalInputError(f"array {k!r} holds a value that is not a finite number "
                                   f"(element {int(bad[0])}): the model file is damaged "
                                   "(identify again)", bin_path, None, k)
    return arrays, ""


def _binary_named(path: Path, doc: dict[str, Any]) -> Path | None:
    """The binary part a format-3 JSON names (in its folder), or None if it names none."""
    block = doc.get("arrays")
    if isinstance(block, dict) and isinstance(block.get("file"), str):
        return path.parent / Path(block["file"]).name
    return None


def load_model(path: str | Path) -> IdentificationResult:
    """Load a model file.

    Parameters
    ----------
    path : str or Path
        ``MODEL.json`` (format 3 reads ``MODEL.npz`` beside it; formats 2 and 1 are one
        JSON file).

    Returns
    -------
    IdentificationResult
        With ``predict`` and ``function_std`` available (fitted values and residuals too in
        format 3). A format-3 JSON whose binary part is missing or does not match loads
        without uncertainty: ``uncertainty_missing`` says why, a
        :class:`ModelFileWarning` is issued, and ``predict`` refuses.

    Raises
    ------
    VolcalInputError
        If the file is missing or not a valid model; a value that is not a finite
        number, or not plausible (:func:`~volcal.identify.result.check_model_values`),
        in the JSON or in its binary part (the message names the file and the key).
    """
    path = model_path(path)
    if path.suffix.lower() == BINARY_SUFFIX:
        raise VolcalInputError(f"this is the binary part of a model; give the model's JSON "
                               f"({path.with_suffix('.json').name})", path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"invalid JSON: {exc}", path) from None
    if not isinstance(doc, dict):
        raise VolcalInputError("not a volcal model file", path)
    if doc.get("format") != MODEL_FORMAT:
        return IdentificationResult.from_dict(doc, str(path))
    arrays, why = _read_binary(path, doc)
    result = IdentificationResult.from_dict(doc, str(path), arrays, why or None)
    if arrays is None:
        result.uncertainty_file = str(_binary_named(path, doc) or path)
        warnings.warn(f"{path}: loaded without uncertainty: {why}", ModelFileWarning,
                      stacklevel=2)
    return result


def load_model_errors(path: str | Path) -> MachineErrors:
    """The estimated error functions of a model file.

    Parameters
    ----------
    path : str or Path
        ``MODEL.json``.

    Returns
    -------
    MachineErrors
    """
    return load_model(path).errors


def model_session_differences(model: IdentificationResult, session: Session) -> list[str]:
    """What differs between a model's session identity and a session.

    Parameters
    ----------
    model : IdentificationResult
        A model (fresh or loaded).
    session : Session
        The session it is used with.

    Returns
    -------
    list of str
        One plain phrase per difference (empty when they match). A model of format
        ``volcal-model/1`` carries no identity: only its name, chain and travel are
        compared. The readings match when the model's hash is the session's
        (:func:`~volcal.identify.record.readings_sha256`: the same whether the reader
        dropped the missed captures or kept them as NaN), or the hash older volcal
        versions wrote for a session holding NaN readings (``legacy=True``).
    """
    from volcal.identify.record import readings_sha256, session_identity

    now = session_identity(session)
    ident = model.session
    if ident is None:  # format 1: the model's own name, chain and travel
        tr = tuple((float(a), float(b)) for a, b in model.errors.travel)
        name, chain, digest = model.name, str(model.errors.chain), None
    else:
        tr, name, chain, digest = ident.travel_mm, ident.name, ident.chain, ident.readings_sha256
    out = []
    if name != now.name:
        out.append(f"machine name {name!r} (model) vs {now.name!r} (session)")
    if chain != now.chain:
        out.append(f"chain {chain} (model) vs {now.chain} (session)")
    if not np.allclose(np.asarray(tr), np.asarray(now.travel_mm), rtol=0, atol=1e-6):
        fmt = " x ".join(f"{a:g}..{b:g}" for a, b in tr)
        fmt2 = " x ".join(f"{a:g}..{b:g}" for a, b in now.travel_mm)
        out.append(f"travel {fmt} mm (model) vs {fmt2} mm (session)")
    if ident is not None and digest is not None and digest != now.readings_sha256 \
            and digest != readings_sha256(session, legacy=True)[0]:
        out.append(f"readings: the model was identified from {ident.n_readings} readings "
                   f"(sha256 {digest[:12]}), the session has {now.n_readings} "
                   f"(sha256 {now.readings_sha256[:12]})")
    return out


def check_model_session(model: IdentificationResult, session: Session, force: bool = False,
                        model_path: str | Path | None = None) -> list[str]:
    """Refuse a model that was not identified from this session.

    Parameters
    ----------
    model : IdentificationResult
        A model (fresh or loaded).
    session : Session
        The session it is used with.
    force : bool
        Return the differences instead of raising (``--force``).
    model_path : str or Path, optional
        Model file, named in the message.

    Returns
    -------
    list of str
        The differences (empty when they match, or only reported when ``force``).

    Raises
    ------
    VolcalInputError
        If they differ and ``force`` is false; the message names every difference.
    """
    diffs = model_session_differences(model, session)
    if diffs and not force:
        where = session.path / "session.toml" if session.path else None
        raise VolcalInputError("the model does not belong to this session: "
                               + "; ".join(diffs)
                               + (f" (model {model_path})" if model_path else "")
                               + "; identify this session again, or give --force to use it "
                                 "anyway", where)
    return diffs


def check_model_file_session(model: str | Path, session: str | Path | None,
                             force: bool = False) -> list[str]:
    """:func:`check_model_session` for a model file and a session folder.

    Parameters
    ----------
    model : str or Path
        ``MODEL.json`` (an error table ``.csv`` carries no identity and is not checked).
    session : str or Path or None
        Session folder (nothing is checked when ``None``).
    force : bool
        Report the differences instead of refusing them.

    Returns
    -------
    list of str
        The differences found.
    """
    if session is None or not is_model_file(model):
        return []
    from volcal.session.format import read_session

    return check_model_session(load_model(model), read_session(session, require_deviation=False),
                               force, model)
