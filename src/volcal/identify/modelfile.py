"""Read identified model files (``volcal-model/1``, written by ``volcal identify``)."""

from __future__ import annotations

import json
from pathlib import Path

from volcal.errors import VolcalInputError
from volcal.identify.result import IdentificationResult
from volcal.model.errorfunctions import MachineErrors

__all__ = ["load_model", "load_model_errors"]


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
