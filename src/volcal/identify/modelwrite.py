"""Write model files (``volcal-model/3``): ``MODEL.npz``, then ``MODEL.json``.

The writer of :mod:`volcal.identify.modelfile` (which reads them and re-exports
:func:`write_model` and :func:`binary_path`). It needs nothing of the result class but its
methods (``binary_arrays``, ``to_dict``), so
:meth:`~volcal.identify.result.IdentificationResult.to_json` can call it without an import
cycle.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import VolcalInputError

if TYPE_CHECKING:
    from volcal.identify.result import IdentificationResult

__all__ = ["BINARY_SUFFIX", "binary_path", "write_model"]

BINARY_SUFFIX = ".npz"
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed member time stamps: the same arrays, the same bytes


def binary_path(path: str | Path) -> Path:
    """The binary part written beside a model JSON: ``MODEL.json`` -> ``MODEL.npz``.

    Parameters
    ----------
    path : str or Path
        The model's JSON file.

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        If ``path`` itself ends in ``.npz``.
    """
    path = Path(path)
    if path.suffix.lower() == BINARY_SUFFIX:
        raise VolcalInputError(f"a model file is written as JSON (e.g. MODEL.json); "
                               f"{BINARY_SUFFIX} is the name of its binary part", path)
    return path.with_suffix(BINARY_SUFFIX)



def is_binary_part(path: str | Path) -> bool:
    """True when ``path`` is a model's binary part (:func:`binary_path`) written by volcal.

    A NumPy ``.npz`` archive holding the readings' ``fitted_um``.

    Parameters
    ----------
    path : str or Path
        An existing file.

    Returns
    -------
    bool
    """
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            return "fitted_um.npy" in z.namelist()
    except (OSError, zipfile.BadZipFile):
        return False

def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """An uncompressed ``.npz`` of the arrays, byte for byte the same for the same arrays."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as zf:
        for name, a in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_STORED
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(a), allow_pickle=False)
            zf.writestr(info, member.getvalue())
    return buf.getvalue()


def _json_text(obj: Any, indent: int = 0) -> str:
    """JSON with one key per line, but a list or table of plain values on one line.

    Readable, and fast: the one-line parts go through the C encoder (``json.dumps`` with
    an ``indent`` falls back to the pure-Python encoder, 0.8 s for a format-2 model).
    """
    if isinstance(obj, dict) and any(isinstance(v, dict | list) for v in obj.values()):
        pad = " " * (indent + 1)
        items = [f"{pad}{json.dumps(str(k))}: {_json_text(v, indent + 1)}"
                 for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    if isinstance(obj, list) and any(isinstance(v, dict | list) for v in obj):
        pad = " " * (indent + 1)
        items = [pad + _json_text(v, indent + 1) for v in obj]
        return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"
    return json.dumps(obj, allow_nan=False, ensure_ascii=False)


def write_model(result: IdentificationResult, path: str | Path) -> Path:
    """Write a model file (format ``volcal-model/3``): ``MODEL.npz``, then ``MODEL.json``.

    Both or neither replaced (:func:`volcal.io.atomic.write_together`).

    Parameters
    ----------
    result : IdentificationResult
        A fresh identification (or a model loaded with its uncertainty).
    path : str or Path
        The JSON file; the binary part goes beside it (:func:`binary_path`).

    Returns
    -------
    Path
        The JSON file.

    Raises
    ------
    VolcalInputError
        If the model has no uncertainty (loaded without its binary part) or the name ends
        in ``.npz``.
    """
    from volcal.io.atomic import write_together  # looked up at each call

    path = Path(path)
    bin_path = binary_path(path)
    arrays, index = result.binary_arrays()
    data = _npz_bytes(arrays)
    block = {"file": bin_path.name, "sha256": hashlib.sha256(data).hexdigest(),
             "bytes": len(data),
             "members": {k: {"shape": list(a.shape), "dtype": a.dtype.str}
                         for k, a in arrays.items()}}
    doc = result.to_dict(block, index)
    try:
        text = _json_text(doc) + "\n"
    except ValueError as exc:  # NaN or infinity somewhere: not valid JSON
        raise VolcalInputError(f"the model holds a value JSON cannot store ({exc})",
                               path) from None
    # the binary part first (the JSON names its digest); both or neither replaced
    write_together([(bin_path, data), (path, text)])
    return path
