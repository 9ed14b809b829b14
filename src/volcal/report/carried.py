"""What a set of compensation tables carries, and the error a controller leaves with them.

A controller table corrects only the error components it holds: per-axis pitch tables
(Fanuc, Siemens LEC, Heidenhain, LinuxCNC, the generic CSV) hold the positioning errors
EXX, EYY, EZZ; Siemens CEC tables add the straightness errors and fold the squareness
into them; an ISG list or a 3-D grid carries the whole volumetric error. Each table holds
values at a uniform spacing, rounded to its resolution, which the controller interpolates
linearly (or holds stepwise between points, Fanuc's classic pitch compensation).

:func:`applied_correction` builds a model of what tables written from a model would make
the controller do, the **table model** (the carried components, sampled at the table's
points, rounded and interpolated as the controller does; every other component zero),
and returns its volumetric error: the part of the machine's error the tables remove. The
error left is ``volumetric_error(model) - applied_correction``: for each carried
component the model minus the table as the controller interpolates it, for every other
component the model itself (the first-order volumetric error is linear in the
components).

The report's and the verdict's "after" no longer use it: they read the tables as
written back from their files (:mod:`volcal.compensate.readback`), so a stale, edited or
foreign table shows; the table model remains the independent cross-check of the readers
(``tests/compensate/test_manifest_identity.py``) and says what a folder carries
(:func:`describe`).

The manifest ``volcal-compensation.toml`` says what a folder carries (keys ``carries``,
``resolution_um``, ``spacing_mm``, ``sign``, ``bidirectional``, ``interpolation``); when
a key is missing it is inferred from ``controller_format`` (:data:`FORMAT_CARRIES`,
:data:`FORMAT_RESOLUTION_UM`), and the inference is listed in ``TableSet.assumed``.

References
----------
ISO 230-1:2012, 3.4 (names), annex A (volumetric error); Soons (seed 004), eq. 1
(first-order model). Siemens K3 function manual, 4.4 (LEC/CEC, linear interpolation);
FANUC parameter manual B-63980EN, 3620-3624 (pitch error compensation at points).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

__all__ = ["ALL_21", "FORMAT_CARRIES", "FORMAT_RESOLUTION_UM", "PITCH", "STRAIGHTNESS",
           "TableSet", "applied_correction", "describe", "table_model", "table_set_from_manifest"]

PITCH: tuple[str, ...] = ("EXX", "EYY", "EZZ")
"""Positioning errors: what a per-axis pitch table carries."""

STRAIGHTNESS: tuple[str, ...] = ("EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ")
"""Straightness errors: what cross (CEC) tables add to the pitch tables."""

ALL_21: tuple[str, ...] = COMPONENT_NAMES + SQUARENESS_NAMES
"""The 18 component errors and the 3 squareness errors."""

FORMAT_CARRIES: dict[str, tuple[str, ...]] = {
    "fanuc": PITCH, "siemens-lec": PITCH, "heidenhain": PITCH, "linuxcnc": PITCH,
    "csv": PITCH, "siemens": PITCH + STRAIGHTNESS + SQUARENESS_NAMES,
    "isg": ALL_21, "grid": ALL_21,
}
"""Components carried by each ``controller_format`` when the manifest has no ``carries``
(``siemens`` means LEC and CEC with the squareness folded in; ``siemens-lec`` LEC only)."""

FORMAT_RESOLUTION_UM: dict[str, float] = {
    "fanuc": 1.0, "siemens": 0.001, "siemens-lec": 0.001, "heidenhain": 0.1,
    "linuxcnc": 0.001, "csv": 0.001, "isg": 0.001, "grid": 0.001,
}
"""Rounding step of the table values when the manifest has no ``resolution_um`` [um]:
Fanuc 1 detection unit (IS-B), Heidenhain 4 decimals of mm, the others 6 decimals."""

_KIND = {"pitch": "per-axis pitch only", "cross": "pitch + straightness/squareness (cross)",
         "volumetric": "full volumetric (all 21 errors)"}


@dataclass(frozen=True)
class TableSet:
    """What a set of compensation tables carries and how the controller applies it.

    Attributes
    ----------
    carries : tuple of str
        ISO 230-1 names of the components corrected.
    spacing_mm : float
        Distance between table points [mm].
    resolution_um : float
        Rounding step of the values [um] (urad for rotations).
    interpolation : str
        ``'linear'`` between points, or ``'step'`` (the value of the last point passed
        is held up to the next point).
    grid : bool
        A 3-D grid of volumetric error vectors, interpolated trilinearly.
    sign : str
        ``'error'`` or ``'correction'`` (the residual assumes the controller applies it
        with the sign it expects).
    bidirectional : bool
        Separate tables per approach direction (the model's reversal is corrected too).
    controller_format : str
        Format name from the manifest.
    assumed : tuple of str
        Manifest keys that were missing and inferred from the format.
    squareness_folded : bool
        Squareness carried inside the straightness (cross) tables, not as constants.
    """

    carries: tuple[str, ...]
    spacing_mm: float
    resolution_um: float
    interpolation: str = "linear"
    grid: bool = False
    sign: str = "error"
    bidirectional: bool = False
    controller_format: str = "?"
    assumed: tuple[str, ...] = field(default_factory=tuple)
    squareness_folded: bool = True

    @property
    def kind(self) -> str:
        """Plain words for the set: per-axis pitch, pitch + cross, or full volumetric."""
        c = set(self.carries)
        if self.grid or c >= set(ALL_21):
            return _KIND["volumetric"]
        if c & set(STRAIGHTNESS):
            return _KIND["cross"]
        return _KIND["pitch"] if c <= set(PITCH) else "partial: " + ", ".join(self.carries)


def table_set_from_manifest(manifest: dict[str, Any], folder: Any = None) -> TableSet:
    """Read what a compensation folder carries from its manifest.

    Parameters
    ----------
    manifest : dict
        Contents of ``volcal-compensation.toml``.
    folder : path, optional
        Folder name used in error messages.

    Returns
    -------
    TableSet

    Raises
    ------
    VolcalInputError
        Unknown format, unknown component names or a bad spacing/resolution.
    """
    fmt = str(manifest.get("controller_format", "?")).lower()
    files = [str(f).upper() for f in manifest.get("files", [])]
    if fmt == "siemens" and files and not any("CEC" in f for f in files):
        fmt_key = "siemens-lec"
    else:
        fmt_key = fmt
    assumed: list[str] = []
    if "carries" in manifest:
        carries = tuple(str(c).upper() for c in manifest["carries"])
        bad = [c for c in carries if c not in ALL_21]
        if bad:
            raise VolcalInputError(f"carries: unknown ISO 230-1 name(s) {', '.join(bad)}",
                                   folder, column="carries")
    elif fmt_key in FORMAT_CARRIES:
        carries = FORMAT_CARRIES[fmt_key]
        assumed.append("carries")
    else:
        raise VolcalInputError(f"unknown controller_format {fmt!r} and no 'carries' key: "
                               "cannot tell what the tables correct", folder,
                               column="controller_format")

    def number(key: str, default: float) -> float:
        if key not in manifest:
            assumed.append(key)
            return default
        try:
            v = float(manifest[key])
        except (TypeError, ValueError):
            v = float("nan")
        if not math.isfinite(v) or v <= 0:
            raise VolcalInputError(f"{key} = {manifest[key]!r}: expected a positive number",
                                   folder, column=key)
        return v

    spacing = number("spacing_mm", 20.0)
    resolution = number("resolution_um", FORMAT_RESOLUTION_UM.get(fmt_key, 0.001))
    if "interpolation" in manifest:
        interp = str(manifest["interpolation"]).lower()
        if interp not in ("linear", "step"):
            raise VolcalInputError(f"interpolation = {interp!r}: expected linear or step",
                                   folder, column="interpolation")
    else:
        interp = "step" if fmt_key == "fanuc" else "linear"
        assumed.append("interpolation")
    return TableSet(carries, spacing, resolution, interp, fmt_key == "grid",
                    str(manifest.get("sign", "error")), bool(manifest.get("bidirectional",
                                                                          False)),
                    fmt, tuple(assumed), fmt_key not in ("isg", "grid"))


def _grid(lo: float, hi: float, spacing: float) -> NDArray[np.float64]:
    """Table points from ``lo`` with ``spacing`` covering ``hi`` (as the writers do)."""
    n = max(1, math.ceil((hi - lo) / spacing - 1e-9))
    return lo + spacing * np.arange(n + 1, dtype=np.float64)


def _quantize(v: NDArray[np.float64], res: float) -> NDArray[np.float64]:
    return np.round(np.asarray(v, dtype=float) / res) * res + 0.0


def _as_function(p: NDArray[np.float64], v: NDArray[np.float64], interpolation: str):
    """Nodes and values whose linear interpolation is the controller's rule."""
    if interpolation == "linear" or p.size < 2:
        return p, v
    eps = 1e-7 * float(np.min(np.diff(p)))
    nodes = np.empty(2 * p.size - 1)
    vals = np.empty((2 * p.size - 1,) + v.shape[1:])
    nodes[0::2], vals[0::2] = p, v
    nodes[1::2], vals[1::2] = p[1:] - eps, v[:-1]  # hold the last point's value
    return nodes, vals


# squareness -> (lever axis, output axis, factor urad * mm -> um), docs/conventions.md
_SQ_TERMS = {"EC0Y": (1, 0, -1e-3), "EB0Z": (2, 0, +1e-3), "EA0Z": (2, 1, -1e-3)}


def table_model(errors: MachineErrors, tables: TableSet) -> MachineErrors:
    """The carried components as the controller applies them; every other one zero.

    Parameters
    ----------
    errors : MachineErrors
        The model the tables were written from.
    tables : TableSet
        What the tables carry, their spacing, resolution and interpolation.

    Returns
    -------
    MachineErrors
        Component functions sampled at the table points (from the start of each travel,
        ``spacing_mm`` apart), rounded to ``resolution_um`` and interpolated as the
        controller does; squareness folded into the straightness tables where the format
        does that (Siemens CEC), as a rounded constant otherwise.
    """
    carried = set(tables.carries)
    t = errors.travel
    nodes, values = [], []
    sq = np.zeros(3)
    for k in range(3):
        p = _grid(t[k, 0], t[k, 1], tables.spacing_mm)
        v = errors.component(k, p)
        keep = np.array([COMPONENT_NAMES[6 * k + c] in carried for c in range(6)])
        v = np.where(keep[None, :], v, 0.0)
        if tables.squareness_folded:
            for name, (lever, out, f) in _SQ_TERMS.items():
                if lever == k and name in carried and keep[out]:
                    v[:, out] += f * errors.squareness[SQUARENESS_NAMES.index(name)] * p
        n, vals = _as_function(p, _quantize(v, tables.resolution_um), tables.interpolation)
        nodes.append(n)
        values.append(vals)
    if not tables.squareness_folded:
        for j, name in enumerate(SQUARENESS_NAMES):
            if name in carried:
                sq[j] = _quantize(errors.squareness[j], tables.resolution_um)
    rev = errors.reversal if tables.bidirectional else np.zeros(3)
    return MachineErrors(errors.chain_obj, nodes, values, sq, rev, name="tables")


def applied_correction(errors: MachineErrors, tables: TableSet, points: ArrayLike,
                       tool_offset: ArrayLike | None = None) -> NDArray[np.float64]:
    """The error the tables remove at the given points [um] (error sign).

    Parameters
    ----------
    errors : MachineErrors
        The model the tables were written from.
    tables : TableSet
        What the tables carry.
    points : array_like, shape (m, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,), optional
        Target point on the tool [mm] (a 3-D grid is written for one tool point, the
        grid's own; it is applied unchanged to every tool point).

    Returns
    -------
    ndarray, shape (m, 3)
        Volumetric error carried by the tables, as the controller applies it [um]; the
        error left is ``volumetric_error(errors, points) - applied_correction(...)``.
    """
    q = np.asarray(points, dtype=float).reshape(-1, 3)
    if tables.grid:
        t = errors.travel
        axes = [_grid(t[k, 0], t[k, 1], tables.spacing_mm) for k in range(3)]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        if g.shape[0] > 2_000_000:
            raise VolcalInputError(f"a 3-D grid of {g.shape[0]} points at "
                                   f"{tables.spacing_mm:g} mm is too large to evaluate")
        from volcal.compensate.readback import trilinear

        v = _quantize(volumetric_error(errors, g, tool_offset), tables.resolution_um)
        return trilinear(axes, v.reshape(*(a.size for a in axes), 3), q)
    return volumetric_error(table_model(errors, tables), q, tool_offset)


def describe(tables: TableSet) -> str:
    """One sentence: what the tables carry and how they are applied.

    Parameters
    ----------
    tables : TableSet
        What the tables carry.

    Returns
    -------
    str
    """
    what = ("the volumetric error vector on a 3-D grid" if tables.grid
            else ", ".join(tables.carries))
    s = (f"{tables.kind}: {what}; points {tables.spacing_mm:g} mm apart, values rounded to "
         f"{tables.resolution_um:g} µm, {tables.interpolation} interpolation"
         + (", one table per approach direction" if tables.bidirectional else ""))
    if tables.assumed:
        s += (f" (not in the manifest, inferred from the format "
              f"'{tables.controller_format}': {', '.join(tables.assumed)})")
    return s + "."

