"""Registry of compensation formats and the folder writer used by ``volcal compensate``."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from volcal.compensate import fanuc, heidenhain, linuxcnc, siemens
from volcal.compensate.bidirectional import DirectionalErrors
from volcal.compensate.generic import generic_files
from volcal.compensate.heidenhain import heidenhain_files
from volcal.compensate.linuxcnc import linuxcnc_files
from volcal.compensate.manifest import MANIFEST, errors_digest, identity_of_errors
from volcal.compensate.siemens import siemens_files
from volcal.compensate.tables import sign_factor
from volcal.compensate.volumetric import ISG_DEFAULT_SIGN, ISG_SIGN_SOURCE, grid_files, isg_files
from volcal.errors import ParameterError, VolcalInputError
from volcal.io.atomic import atomic_dir
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES
from volcal.session.identity import MachineIdentity

MANIFEST_FORMAT = "volcal-compensation/2"
"""Format of the manifest: ``/2`` adds ``[machine]`` (identity) and ``model_sha256``."""

PITCH = ("EXX", "EYY", "EZZ")
STRAIGHTNESS = ("EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ")
ALL_21 = (*COMPONENT_NAMES, *SQUARENESS_NAMES)


@dataclass(frozen=True)
class FormatInfo:
    """What a controller format carries and how it is signed.

    Attributes
    ----------
    sign : str
        The controller's own convention, written by default.
    sign_source : str
        Manual and page the convention comes from.
    carries : tuple of str
        ISO 230-1 names of the errors the table set corrects.
    resolution_um : float
        Rounding step of the values [um] (Fanuc: per count, times ``unit_um`` x
        magnification).
    bidirectional : bool
        The format has separate values for the two directions of travel.
    """

    sign: str
    sign_source: str
    carries: tuple[str, ...]
    resolution_um: float
    bidirectional: bool = False


FORMAT_INFO: dict[str, FormatInfo] = {
    "fanuc": FormatInfo(fanuc.DEFAULT_SIGN, fanuc.SIGN_SOURCE, PITCH, 1.0, True),
    "siemens": FormatInfo(siemens.DEFAULT_SIGN, siemens.SIGN_SOURCE,
                          PITCH + STRAIGHTNESS + SQUARENESS_NAMES, siemens.RESOLUTION_UM),
    "heidenhain": FormatInfo(heidenhain.DEFAULT_SIGN, heidenhain.SIGN_SOURCE, PITCH,
                             heidenhain.RESOLUTION_UM, True),
    "linuxcnc": FormatInfo(linuxcnc.DEFAULT_SIGN, linuxcnc.SIGN_SOURCE, PITCH,
                           linuxcnc.RESOLUTION_UM, True),
    "csv": FormatInfo("error", "volcal's generic table: the column name states the sign",
                      PITCH, 0.001),
    "isg": FormatInfo(ISG_DEFAULT_SIGN, ISG_SIGN_SOURCE, ALL_21, 0.001),
    "grid": FormatInfo("error", "volcal's 3-D grid: the column names state the sign",
                       ALL_21, 0.001),
}
"""Format name -> its default sign (with source), what it corrects, its resolution."""


@dataclass(frozen=True)
class CompensationOptions:
    """Options of ``volcal compensate``.

    Parameters
    ----------
    sign : str, optional
        ``'error'`` or ``'correction'``; default (None) the controller's own convention
        (:data:`FORMAT_INFO`).
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
    fanuc_series : str
        Fanuc parameter syntax: ``'30i'`` (current, default) or ``'16i'`` (older).
    linuxcnc_type : int
        LinuxCNC ``COMP_FILE_TYPE``: 1 (trims, default) or 0.
    directional : DirectionalErrors, optional
        Measured reversal for bidirectional tables (from the session's linear tests).
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
    fanuc_series: str = "30i"
    linuxcnc_type: int = 1
    directional: DirectionalErrors | None = None

    def __post_init__(self) -> None:
        """Reject option values no controller table can be built from."""
        if self.sign is not None:
            sign_factor(self.sign)
        if not math.isfinite(self.spacing) or self.spacing <= 0:
            raise ParameterError(f"{{spacing=}}{self.spacing}: expected a positive distance [mm]")
        if self.max_points is not None and self.max_points < 2:
            raise ParameterError(f"{{max_points=}}{self.max_points}: expected at least 2")
        if not math.isfinite(self.unit_um) or self.unit_um <= 0:
            raise ParameterError(f"{{unit_um=}}{self.unit_um}: expected a positive detection "
                                 "unit [um]")
        if self.max_increment < 1:
            raise ParameterError(f"{{max_increment=}}{self.max_increment}: expected at least 1")

    def sign_for(self, fmt: str) -> str:
        """The sign written for ``fmt``: the override or the controller's convention.

        Parameters
        ----------
        fmt : str
            A key of :data:`FORMATS`.

        Returns
        -------
        str
        """
        return self.sign if self.sign is not None else FORMAT_INFO[fmt].sign


def _fanuc(e: MachineErrors, o: CompensationOptions, sign: str) -> dict[str, str]:
    ref = e.travel[:, 0] if o.reference_mm is None else np.asarray(o.reference_mm)
    return fanuc.fanuc_files(e, o.spacing, sign, ref, o.unit_um, o.magnification,
                             o.max_increment, o.max_points or 1024, o.fanuc_series,
                             o.directional)


FORMATS: dict[str, Callable[[MachineErrors, CompensationOptions, str], dict[str, str]]] = {
    "fanuc": _fanuc,
    "siemens": lambda e, o, s: siemens_files(e, o.spacing, s, o.max_points or 5000,
                                             o.include_squareness),
    "heidenhain": lambda e, o, s: heidenhain_files(e, o.spacing, s, o.max_points,
                                                   o.directional),
    "linuxcnc": lambda e, o, s: linuxcnc_files(e, o.spacing, s, o.linuxcnc_type,
                                               o.max_points or linuxcnc.MAX_ENTRIES,
                                               o.directional),
    "csv": lambda e, o, s: generic_files(e, o.spacing, s, o.max_points),
    "isg": lambda e, o, s: isg_files(e, o.spacing, s, o.max_points),
    "grid": lambda e, o, s: grid_files(e, o.spacing, s, o.tool_offset,
                                       o.max_points or 1_000_000),
}
"""Format name -> function returning the files (name -> text) of that format."""


def write_compensation(errors: MachineErrors, fmt: str, folder: str | Path,
                       options: CompensationOptions, source: str = "",
                       machine: MachineIdentity | None = None,
                       rotary: tuple[dict[str, str], list[dict[str, Any]]] | None = None
                       ) -> list[str]:
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
        Sign (default: the controller's convention), spacing, limits.
    source : str
        Name of the model file, recorded in the manifest.
    machine : MachineIdentity, optional
        The machine the tables are for (:mod:`volcal.session.identity`), recorded as the
        manifest's ``[machine]`` table; default what the model says of itself (name,
        chain, travel). ``model_sha256`` records the digest of ``errors``
        (:func:`volcal.compensate.manifest.errors_digest`).
    rotary : tuple, optional
        The rotary axes' tables (:func:`volcal.compensate.rotary.rotary_tables`: files,
        manifest entries), written beside the linear ones and listed in the manifest's
        ``files`` and ``[[rotary]]``.

    Returns
    -------
    list of str
        Names of the files written (without the manifest).
    """
    if fmt not in FORMATS:
        raise VolcalInputError(f"unknown format {fmt!r}: expected one of {', '.join(FORMATS)}")
    sign = options.sign_for(fmt)
    info = FORMAT_INFO[fmt]
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or (any(folder.iterdir())
                                                    and not (folder / MANIFEST).is_file())):
        raise VolcalInputError("output exists and is not a volcal compensation folder", folder)
    files = FORMATS[fmt](errors, options, sign)
    if rotary is not None:
        clash = sorted(set(files) & set(rotary[0]))
        if clash:
            raise VolcalInputError(f"rotary table {clash[0]} would replace a linear one")
        files = {**files, **rotary[0]}
        if fmt == "fanuc":
            from volcal.compensate.rotary.fanuc import (
                DEFAULT_REFERENCE_NUMBER,
                TABLE_POINTS,
                fanuc_point_clash,
            )

            clash2 = fanuc_point_clash(files)
            if clash2 is not None:
                raise ParameterError(f"Fanuc pitch error compensation: {clash2} (one table "
                                     "for all axes: the linear axes' points count from 0, "
                                     f"the rotary axes' from {DEFAULT_REFERENCE_NUMBER}, or "
                                     f"lower where they would not fit below {TABLE_POINTS}); "
                                     "use a larger {spacing} for the linear axes or a larger "
                                     "{rotary_spacing}")
    carries = list(info.carries)
    if fmt == "siemens" and not options.include_squareness:
        carries = [c for c in carries if c not in SQUARENESS_NAMES]
    resolution = (options.unit_um * options.magnification if fmt == "fanuc"
                  else info.resolution_um)
    bidir = bool(info.bidirectional and options.directional is not None
                 and any(options.directional.has(k) for k in range(3)))
    if machine is None:
        machine = identity_of_errors(errors)
    manifest = {"format": MANIFEST_FORMAT, "controller_format": fmt,
                "sign": sign, "sign_default": info.sign, "sign_source": info.sign_source,
                "spacing_mm": options.spacing, "resolution_um": resolution,
                "carries": carries, "bidirectional": bidir,
                # Fanuc outputs a point's value once the axis passes it; the others
                # interpolate linearly between points (see docs/compensation.md)
                "interpolation": "step" if fmt == "fanuc" else "linear",
                "model": source, "model_sha256": errors_digest(errors),
                "chain": errors.chain_obj.code, "files": sorted(files)}
    if fmt == "fanuc":  # what the Fanuc files do not hold, needed to read them back
        ref = errors.travel[:, 0] if options.reference_mm is None else options.reference_mm
        manifest["fanuc_reference_mm"] = [float(v) for v in ref]
        manifest["fanuc_unit_um"] = options.unit_um
    if fmt == "linuxcnc":
        manifest["linuxcnc_type"] = options.linuxcnc_type
    if rotary is not None and rotary[1]:
        manifest["rotary"] = rotary[1]
    manifest["machine"] = machine.to_dict()
    with atomic_dir(folder) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8", newline="\n")
        (tmp / MANIFEST).write_text(toml_dumps(manifest), encoding="utf-8")
    return sorted(files)


def write_rotary_compensation(fmt: str, folder: str | Path, sign: str,
                              machine: MachineIdentity,
                              rotary: tuple[dict[str, str], list[dict[str, Any]]]
                              ) -> list[str]:
    """Write the rotary tables alone, without a linear model (a rotary-only calibration).

    The manifest is :func:`write_compensation`'s without the linear keys (``carries``,
    ``model_sha256``, ``spacing_mm``...): ``linear = false`` says the folder holds no
    table of the linear axes (:func:`volcal.compensate.readback.read_written_tables`
    refuses to read linear tables from it), ``model = ""``; ``files``, ``[[rotary]]`` and
    ``[machine]`` as with a model.

    Parameters
    ----------
    fmt : str
        A format with rotary tables (:data:`volcal.compensate.rotary.ROTARY_FORMATS`).
    folder : str or Path
        Output folder (new, empty, or written by ``volcal compensate`` before).
    sign : str
        The sign of the rotary tables written.
    machine : MachineIdentity
        The machine the tables are for (the session's).
    rotary : tuple
        The rotary tables (:func:`volcal.compensate.rotary.rotary_tables`: files, manifest
        entries).

    Returns
    -------
    list of str
        Names of the files written (without the manifest).
    """
    from volcal.compensate.rotary import ROTARY_FORMATS

    if fmt not in ROTARY_FORMATS:
        raise VolcalInputError(f"the {fmt} format has no rotary tables (expected one of "
                               f"{', '.join(ROTARY_FORMATS)})")
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or (any(folder.iterdir())
                                                    and not (folder / MANIFEST).is_file())):
        raise VolcalInputError("output exists and is not a volcal compensation folder", folder)
    files = rotary[0]
    manifest: dict[str, Any] = {
        "format": MANIFEST_FORMAT, "controller_format": fmt, "sign": sign,
        "sign_default": ROTARY_FORMATS[fmt], "linear": False, "model": "",
        "files": sorted(files), "rotary": rotary[1], "machine": machine.to_dict()}
    with atomic_dir(folder) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8", newline="\n")
        (tmp / MANIFEST).write_text(toml_dumps(manifest), encoding="utf-8")
    return sorted(files)
