"""Model files: read them (``volcal-model/2`` or ``/1``); check a model's session.

Written by ``volcal identify``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from volcal.errors import VolcalInputError
from volcal.identify.result import IdentificationResult
from volcal.model.errorfunctions import MachineErrors

if TYPE_CHECKING:
    from volcal.session.format import Session

__all__ = ["check_model_session", "load_model", "load_model_errors",
           "model_session_differences"]


def load_model(path: str | Path) -> IdentificationResult:
    """Load a model file.

    Parameters
    ----------
    path : str or Path
        ``MODEL.json``.

    Returns
    -------
    IdentificationResult
        With ``predict`` and ``function_std`` available (no residuals).

    Raises
    ------
    VolcalInputError
        If the file is missing or not a valid model.
    """
    path = Path(path)
    if not path.is_file():
        raise VolcalInputError("model file not found", path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"invalid JSON: {exc}", path) from None
    if not isinstance(doc, dict):
        raise VolcalInputError("not a volcal model file", path)
    return IdentificationResult.from_dict(doc, str(path))


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
        compared.
    """
    from volcal.identify.record import session_identity

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
    if digest is not None and digest != now.readings_sha256:
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
    if session is None or Path(model).suffix.lower() != ".json":
        return []
    from volcal.session.format import read_session

    return check_model_session(load_model(model), read_session(session, require_deviation=False),
                               force, model)
