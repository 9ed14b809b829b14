"""Registry of compensation formats and the folder writer used by ``volcal compensate``."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from volcal.compensate.fanuc import fanuc_files
from volcal.compensate.generic import generic_files
from volcal.compensate.heidenhain import heidenhain_files
from volcal.compensate.linuxcnc import MAX_ENTRIES, linuxcnc_files
from volcal.compensate.siemens import siemens_files
from volcal.compensate.tables import sign_factor
from volcal.compensate.volumetric import grid_files, isg_files
from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

MANIFEST = "volcal-compensation.toml"
ALL21: tuple[str, ...] = tuple(COMPONENT_NAMES) + tuple(SQUARENESS_NAMES)


@dataclass(frozen=True)
class CompensationOptions:
    """Options of ``volcal compensate``.

    Parameters
    ----------
    sign : str, optional
        ``'error'`` or ``'correction'``; default (None) the format's own convention
        (:data:`DEFAULT_SIGN`). Anything else is an override.
    spacing : float
        Distance between compensation points (and 3-D grid spacing) [mm].
    max_points : int, optional
        Controller limit of points (per table; Fanuc: the whole table). Default per
        format: Fanuc 1024, Siemens 5000, LinuxCNC 256, others unlimited (3-D grid 10^6).
    reference_mm : array_like, shape (3,), optional
        Fanuc reference position [mm]; default the start of each travel.
    unit_um : float
        Fanuc detection unit [um].
    magnification : int
        Fanuc magnification (parameter 3623).
    max_increment : int
        Fanuc largest value per point.
    include_squareness : bool
        Siemens CEC tables carry the squareness terms.
    tool_offset : array_like, shape (3,), optional
        Target point of the 3-D grid [mm].
    linuxcnc_type : int
        LinuxCNC ``COMP_FILE_TYPE`` (1: trims, 0: actual positions).
    reversal_um : sequence of 3 callables, optional
        Per axis, ``f(positions [mm]) -> reverse minus forward positioning error [um]``
        from bidirectional ISO 230-2 runs; used by formats with two directions.
    """

    sign: str | None = None
    spacing: float = 20.0
    max_points: int | None = None
    reference_mm: tuple[float, float, float] | None = None
    unit_um: float = 1.0
    magnification: int = 1
    max_increment: int = 7
    include_squareness: bool = True
    tool_offset: tuple[float, float, float] | None = None
    linuxcnc_type: int = 1
    reversal_um: tuple | None = None

    def __post_init__(self) -> None:
        """Reject option values no controller table can be built from."""
        if not math.isfinite(self.spacing) or self.spacing <= 0:
            raise VolcalInputError(f"--spacing {self.spacing}: expected a positive distance [mm]")
        if self.max_points is not None and self.max_points < 2:
            raise VolcalInputError(f"--max-points {self.max_points}: expected at least 2")
        if not math.isfinite(self.unit_um) or self.unit_um <= 0:
            raise VolcalInputError(f"--unit-um {self.unit_um}: expected a positive detection "
                                   "unit [um]")
        if self.max_increment < 1:
            raise VolcalInputError(f"--max-increment {self.max_increment}: expected at least 1")


def _fanuc(e: MachineErrors, o: CompensationOptions) -> dict[str, str]:
    ref = e.travel[:, 0] if o.reference_mm is None else np.asarray(o.reference_mm)
    return fanuc_files(e, o.spacing, o.sign or DEFAULT_SIGN["fanuc"], ref, o.unit_um,
                       o.magnification, o.max_increment, o.max_points or 1024)


DEFAULT_SIGN: dict[str, str] = {
    "fanuc": "correction", "siemens": "error", "heidenhain": "error", "csv": "error",
    "isg": "error", "grid": "error", "linuxcnc": "correction",
}
"""Each format's own sign convention (sources in docs/compensation.md)."""

SIGN_SOURCE: dict[str, str] = {
    "fanuc": "FANUC parameter manual B-63950EN/02 (30i), pitch error compensation: the "
             "compensation pulses are added to the command",
    "siemens": "SINUMERIK 840D sl function manual Extended functions (K3), LEC: a positive "
               "compensation value moves the axis in the negative direction; CEC taken the "
               "same (check on the machine)",
    "heidenhain": "not stated in a public HEIDENHAIN manual; volcal writes the error (check "
                  "on the machine)",
    "csv": "volcal convention (ISO 230-1 error = actual - commanded)",
    "isg": "Beckhoff TF5280 / ISG volumetric compensation: tables hold the errors "
           "(negate flips them)",
    "grid": "volcal convention (ISO 230-1 error = actual - commanded)",
    "linuxcnc": "LinuxCNC src/emc/motion/usrmotintf.cc usrmotLoadComp: trim = nominal - "
                "actual, added to the command",
}
"""Where each default sign comes from (manual and place), recorded in the manifest."""

CARRIES: dict[str, tuple[str, ...]] = {
    "fanuc": ("EXX", "EYY", "EZZ"), "heidenhain": ("EXX", "EYY", "EZZ"),
    "csv": ("EXX", "EYY", "EZZ"), "linuxcnc": ("EXX", "EYY", "EZZ"),
    "siemens": ("EXX", "EYY", "EZZ", "EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ"),
    "isg": ALL21, "grid": ALL21,
}
"""ISO 230-1 names each format's table set corrects (Siemens adds the squareness
terms when ``include_squareness``)."""

RESOLUTION_UM: dict[str, float] = {
    "fanuc": 1.0, "siemens": 0.001, "heidenhain": 0.1, "csv": 0.001, "isg": 0.001,
    "grid": 0.001, "linuxcnc": 0.001,
}


def _s(o: CompensationOptions, fmt: str) -> str:
    return o.sign or DEFAULT_SIGN[fmt]


FORMATS: dict[str, Callable[[MachineErrors, CompensationOptions], dict[str, str]]] = {
    "fanuc": _fanuc,
    "siemens": lambda e, o: siemens_files(e, o.spacing, _s(o, "siemens"), o.max_points or 5000,
                                          o.include_squareness),
    "heidenhain": lambda e, o: heidenhain_files(e, o.spacing, _s(o, "heidenhain"),
                                                o.max_points, o.reversal_um),
    "csv": lambda e, o: generic_files(e, o.spacing, _s(o, "csv"), o.max_points),
    "isg": lambda e, o: isg_files(e, o.spacing, _s(o, "isg"), o.max_points),
    "grid": lambda e, o: grid_files(e, o.spacing, _s(o, "grid"), o.tool_offset,
                                    o.max_points or 1_000_000),
    "linuxcnc": lambda e, o: linuxcnc_files(e, o.spacing, _s(o, "linuxcnc"),
                                            o.max_points or MAX_ENTRIES, o.linuxcnc_type,
                                            o.reversal_um),
}
"""Format name -> function returning the files (name -> text) of that format."""


def write_compensation(errors: MachineErrors, fmt: str, folder: str | Path,
                       options: CompensationOptions, source: str = "") -> list[str]:
    """Write the compensation files of one format into a folder, atomically.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    fmt : str
        A key of :data:`FORMATS`.
    folder : str or Path
        Output folder; built aside and moved into place. An existing folder is replaced
        only if it is empty or holds ``volcal-compensation.toml``.
    options : CompensationOptions
        Sign, spacing, limits.
    source : str
        Name of the model file, recorded in the manifest.

    Returns
    -------
    list of str
        Names of the files written (without the manifest).
    """
    if fmt not in FORMATS:
        raise VolcalInputError(f"unknown format {fmt!r}: expected one of {', '.join(FORMATS)}")
    sign = options.sign or DEFAULT_SIGN[fmt]
    sign_factor(sign)
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or (any(folder.iterdir())
                                                    and not (folder / MANIFEST).is_file())):
        raise VolcalInputError("output exists and is not a volcal compensation folder", folder)
    files = FORMATS[fmt](errors, options)
    carries = list(CARRIES[fmt])
    if fmt == "siemens" and options.include_squareness:
        carries += list(SQUARENESS_NAMES)
    res = RESOLUTION_UM[fmt] * (options.unit_um * options.magnification if fmt == "fanuc"
                                else 1.0)
    manifest = {"format": "volcal-compensation/1", "controller_format": fmt,
                "sign": sign, "sign_default": DEFAULT_SIGN[fmt],
                "sign_source": SIGN_SOURCE[fmt] if sign == DEFAULT_SIGN[fmt]
                else "override (--sign)",
                "spacing_mm": options.spacing, "resolution_um": res, "carries": carries,
                "bidirectional": bool(options.reversal_um is not None
                                      and fmt in ("linuxcnc", "heidenhain")),
                "model": source, "machine": errors.name, "chain": errors.chain_obj.code,
                "files": sorted(files)}
    with atomic_dir(folder) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8", newline="\n")
        (tmp / MANIFEST).write_text(toml_dumps(manifest), encoding="utf-8")
    return sorted(files)
