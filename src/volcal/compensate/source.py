"""Load the error model to compensate: an error table or an identified model file."""

from __future__ import annotations

from pathlib import Path

from volcal.errors import VolcalInputError
from volcal.io.sniff import is_model_file, model_path
from volcal.model.errorfunctions import MachineErrors


def load_errors(path: str | Path) -> MachineErrors:
    """Read ``MODEL.json`` (identified model) or an error table ``MACHINE.csv``.

    Parameters
    ----------
    path : str or Path
        ``.json``: written by ``volcal identify`` (read with
        :func:`volcal.identify.modelfile.load_model_errors`); ``.csv``: a
        ``volcal-errors/1`` table (:func:`volcal.session.errortable.read_error_table`).

    Returns
    -------
    MachineErrors
    """
    path = model_path(path)
    if is_model_file(path):
        try:
            from volcal.identify.modelfile import load_model_errors
        except ImportError:
            raise VolcalInputError("reading identified models needs volcal.identify.modelfile, "
                                   "which is not installed; use an error table CSV", path) from None
        try:
            return load_model_errors(path)
        except VolcalInputError:
            raise
        except (ValueError, KeyError, TypeError) as exc:
            raise VolcalInputError(f"not a volcal model file ({exc})", path) from None
    from volcal.session.errortable import read_error_table

    return read_error_table(path)
