"""Compensation tables as written: read back from their files and applied as the controller does.

The "after" of a report or a tolerance verdict must be what the tables in the folder do,
not what the current model would put into new tables: a stale, edited or foreign table
then shows. :func:`read_written_tables` reads a folder written by ``volcal compensate``
with the reader of its format (``volcal.compensate.fanuc.read_fanuc``,
``siemens.read_lec`` / ``read_cec``, ``heidenhain.read_heidenhain``,
``linuxcnc.read_linuxcnc``, ``generic.read_generic``, ``volumetric.read_isg`` /
``read_grid``) and :meth:`WrittenTables.correction` applies them with the controller's
interpolation rule:

* per-axis tables (pitch, Siemens CEC cross tables): the value at the input axis'
  position, interpolated linearly between points and held constant beyond the first and
  last point (Siemens K3 4.4; Heidenhain; LinuxCNC), or **stepwise** for Fanuc (the value
  of the point at or below the position: Fanuc outputs a point's value once the axis
  passes it; ``interpolation = "step"`` in the manifest); the value is added to the
  output axis;
* the sign: a table in the ``error`` convention removes its value, one in the
  ``correction`` convention removes minus its value (each controller applies the
  convention it expects, ``docs/compensation.md``);
* bidirectional tables (Fanuc 3605#0, Heidenhain ``BACKLASH``, LinuxCNC reverse column):
  the forward table for readings approached in ``+``, the reverse one for ``-``, their
  mean where the direction is not known (a grid of the work zone);
* ISG: the 21 errors read back form a model whose first-order volumetric error at the
  tool point is removed (the ISG kernel applies the whole model, Abbe terms included);
* 3-D grid: the vectors interpolated trilinearly (held constant outside), the same for
  every tool point (the grid is written for one).

References
----------
Siemens SINUMERIK K3 function manual (6FC5397-1BP40-3BA1), 4.4 interpolatory
compensation; FANUC B-63980EN/01 parameters 3620-3627; LinuxCNC ``usrmotLoadComp``;
Beckhoff TF5280 (ISG CSV format).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.compensate.tables import AxisTable, sign_factor
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors

__all__ = ["WrittenTables", "read_written_tables"]


@dataclass
class WrittenTables:
    """The tables of a compensation folder, read back from their files.

    Attributes
    ----------
    folder : Path
        The compensation folder.
    controller_format : str
        ``fanuc``, ``siemens``, ``heidenhain``, ``linuxcnc``, ``csv``, ``isg``, ``grid``.
    forward : list of AxisTable
        Per-axis tables (for bidirectional sets: the positive direction) [mm], [um].
    reverse : list of AxisTable or None
        Negative-direction tables of a bidirectional set.
    interpolation : str
        ``'linear'`` or ``'step'`` (Fanuc).
    volumetric : MachineErrors, optional
        ISG: the 21 errors read back (values in the table's sign).
    volumetric_sign : str
        Sign of ``volumetric`` or of the grid vectors.
    grid_axes : list of ndarray, optional
        3-D grid: positions of the grid along X, Y, Z [mm].
    grid_values : ndarray, optional
        3-D grid: vectors, shape (nx, ny, nz, 3) [um], in ``volumetric_sign``.
    files : list of str
        Files read.
    """

    folder: Path
    controller_format: str
    forward: list[AxisTable] = field(default_factory=list)
    reverse: list[AxisTable] | None = None
    interpolation: str = "linear"
    volumetric: MachineErrors | None = None
    volumetric_sign: str = "error"
    grid_axes: list[NDArray[np.float64]] | None = None
    grid_values: NDArray[np.float64] | None = None
    files: list[str] = field(default_factory=list)

    def _axis_part(self, tables: list[AxisTable], q: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        out = np.zeros((q.shape[0], 3))
        for t in tables:
            x = q[:, t.input_axis]
            if self.interpolation == "step":
                i = np.clip(np.searchsorted(t.positions, x + 1e-9, side="right") - 1, 0,
                            t.positions.size - 1)
                v = t.values[i]
            else:
                v = np.interp(x, t.positions, t.values)
            out[:, t.output_axis] += sign_factor(t.sign) * v
        return out

    def table_correction(self, table: AxisTable, x: ArrayLike) -> NDArray[np.float64]:
        """The error one per-axis table removes at positions of its input axis [um].

        Parameters
        ----------
        table : AxisTable
            One of :attr:`forward` or :attr:`reverse`.
        x : array_like, shape (m,)
            Positions of ``table.input_axis`` [mm].

        Returns
        -------
        ndarray, shape (m,)
            Its value with this folder's interpolation rule, in the error sign (added to
            ``table.output_axis`` by :meth:`correction`).
        """
        q = np.zeros((np.size(x), 3))
        q[:, table.input_axis] = np.asarray(x, dtype=float).reshape(-1)
        return self._axis_part([table], q)[:, table.output_axis]

    def correction(self, points: ArrayLike, tool_offset: ArrayLike | None = None,
                   direction: ArrayLike | None = None) -> NDArray[np.float64]:
        """The error the tables remove at commanded positions [um] (error sign).

        Parameters
        ----------
        points : array_like, shape (m, 3)
            Commanded positions [mm].
        tool_offset : array_like, shape (3,), optional
            Tool point [mm] (used by ISG tables only: per-axis tables shift an axis
            whatever the tool; a grid is written for one tool point).
        direction : array_like of str, shape (m,), optional
            ``'+'`` / ``'-'``: approach direction of each point (bidirectional tables);
            the mean of both tables where not given.

        Returns
        -------
        ndarray, shape (m, 3)
            The error removed by the controller [um]; the error left is the error
            minus this.
        """
        q = np.asarray(points, dtype=float).reshape(-1, 3)
        if self.grid_axes is not None and self.grid_values is not None:
            return sign_factor(self.volumetric_sign) * trilinear(self.grid_axes,
                                                                   self.grid_values, q)
        if self.volumetric is not None:
            from volcal.model.kinematics import volumetric_error

            return sign_factor(self.volumetric_sign) * volumetric_error(self.volumetric, q,
                                                                        tool_offset)
        fwd = self._axis_part(self.forward, q)
        if self.reverse is None:
            return fwd
        rev = self._axis_part(self.reverse, q)
        if direction is None:
            return 0.5 * (fwd + rev)
        d = np.asarray(direction).astype(str).reshape(-1)
        return np.where((d == "+")[:, None], fwd, np.where((d == "-")[:, None], rev,
                                                            0.5 * (fwd + rev)))

    def deviation_after(self, m: Any) -> NDArray[np.float64]:
        """Readings of a test as they would be with the tables active [um].

        Parameters
        ----------
        m : Measurement
            A measured test (deviations along its beam).

        Returns
        -------
        ndarray, shape (n,)
            ``deviation - correction . beam`` at every reading [um], the correction
            being what the tables remove at the reading's commanded position (per
            approach direction for bidirectional tables).
        """
        d = m.columns.get("direction") if m.kind == "linear" else None
        c = self.correction(m.positions, m.tool_offset, d) @ np.asarray(m.beam_direction)
        return np.asarray(m.deviation, dtype=float) - c


def trilinear(axes: list[NDArray[np.float64]], values: NDArray[np.float64],
               q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Trilinear interpolation of grid vectors, held constant outside the grid.

    Parameters
    ----------
    axes : list of 3 ndarray
        Grid positions along X, Y, Z [mm], increasing.
    values : ndarray, shape (nx, ny, nz, c)
        Grid vectors.
    q : ndarray, shape (m, 3)
        Query points [mm].

    Returns
    -------
    ndarray, shape (m, c)
    """
    from volcal.model.errorfunctions import interp_weights

    i0, i1, w = zip(*(interp_weights(a, q[:, k]) for k, a in enumerate(axes)), strict=True)
    out = np.zeros((q.shape[0], values.shape[-1]))
    for cx in (0, 1):
        for cy in (0, 1):
            for cz in (0, 1):
                wt = ((w[0] if cx else 1 - w[0]) * (w[1] if cy else 1 - w[1])
                      * (w[2] if cz else 1 - w[2]))
                idx = ((i1[0] if cx else i0[0]), (i1[1] if cy else i0[1]),
                       (i1[2] if cz else i0[2]))
                out += wt[:, None] * values[idx]
    return out


def _grid_tables(path: Path) -> tuple[list[NDArray[np.float64]], NDArray[np.float64], str]:
    from volcal.compensate.volumetric import read_grid

    pts, vec, sign = read_grid(path)
    axes = [np.unique(np.round(pts[:, k], 9)) for k in range(3)]
    shape = tuple(a.size for a in axes)
    if int(np.prod(shape)) != pts.shape[0]:
        raise VolcalInputError(f"not a regular grid: {pts.shape[0]} points, but "
                               f"{' x '.join(map(str, shape))} positions along X, Y, Z", path)
    idx = tuple(np.searchsorted(axes[k], np.round(pts[:, k], 9)) for k in range(3))
    vals = np.full(shape + (3,), np.nan)
    vals[idx] = vec
    if np.isnan(vals).any():
        raise VolcalInputError("not a regular grid: a point is missing or repeated", path)
    return axes, vals, sign


def _linuxcnc_type(folder: Path, manifest: dict[str, Any]) -> int:
    if "linuxcnc_type" in manifest:
        return int(manifest["linuxcnc_type"])
    from volcal.compensate.linuxcnc import README_FILE

    readme = folder / README_FILE
    if readme.is_file():
        m = re.search(r"COMP_FILE_TYPE = (\d)", readme.read_text(encoding="utf-8",
                                                                  errors="replace"))
        if m:
            return int(m.group(1))
    return 1


def _fanuc(folder: Path, manifest: dict[str, Any], sign: str, bidir: bool, travel: Any
           ) -> tuple[list[AxisTable], list[AxisTable] | None]:
    from volcal.compensate.fanuc import PARAM_FILE, parse_fanuc_parameters, read_fanuc

    ref = manifest.get("fanuc_reference_mm")
    if ref is None:  # volcal-compensation/1: the writer's default, the start of travel
        ref = None if travel is None else np.asarray(travel, dtype=float)[:, 0]
    unit = manifest.get("fanuc_unit_um")
    if unit is None:
        params = parse_fanuc_parameters((folder / PARAM_FILE).read_text(encoding="ascii"),
                                        folder / PARAM_FILE)
        mag = float(params.get(3623, {}).get(1, 1.0)) or 1.0
        unit = float(manifest.get("resolution_um", mag)) / mag
    fwd = read_fanuc(folder, sign, float(unit), ref, "+")
    return fwd, (read_fanuc(folder, sign, float(unit), ref, "-") if bidir else None)


def read_written_tables(folder: str | Path, manifest: dict[str, Any] | None = None,
                        travel: ArrayLike | None = None) -> WrittenTables:
    """Read the tables of a compensation folder with the reader of their format.

    Parameters
    ----------
    folder : str or Path
        Folder written by ``volcal compensate``.
    manifest : dict, optional
        Its ``volcal-compensation.toml`` (read when not given): ``controller_format``,
        ``sign``, ``bidirectional``, ``files`` and, for Fanuc, ``fanuc_reference_mm``
        and ``fanuc_unit_um``; LinuxCNC ``linuxcnc_type``.
    travel : array_like, shape (3, 2), optional
        Travel [mm]: the Fanuc reference position of an older manifest (the start of
        travel, the writer's default).

    Returns
    -------
    WrittenTables

    Raises
    ------
    VolcalInputError
        A missing or damaged table file (naming it), an unknown format.
    """
    from volcal.compensate.manifest import read_manifest

    folder = Path(folder)
    if manifest is None:
        manifest = read_manifest(folder)
    if manifest.get("linear", True) is False:  # write_rotary_compensation: no linear model
        raise VolcalInputError("this folder holds rotary tables only (written without a "
                               "linear model): there are no tables of the linear axes to "
                               "apply; `volcal compensate --session` prints the rotary "
                               "tests' ISO 230-2 A before and after them", folder)
    fmt = str(manifest.get("controller_format", "?")).lower()
    sign = str(manifest.get("sign", "error"))
    sign_factor(sign)
    bidir = bool(manifest.get("bidirectional", False))
    files = [str(f) for f in manifest.get("files", [])]
    for f in files:
        if not (folder / f).is_file():
            raise VolcalInputError(f"table file {f} named in the manifest is missing", folder)
    out = WrittenTables(folder, fmt, files=files)
    try:
        if fmt == "fanuc":
            out.forward, out.reverse = _fanuc(folder, manifest, sign, bidir, travel)
            out.interpolation = "step"
        elif fmt == "siemens":
            from volcal.compensate.siemens import CEC_FILE, LEC_FILE, read_cec, read_lec

            out.forward = read_lec(folder / LEC_FILE, sign)
            if (folder / CEC_FILE).is_file() and (not files or CEC_FILE in files):
                out.forward += read_cec(folder / CEC_FILE, sign)
        elif fmt == "heidenhain":
            from volcal.compensate.heidenhain import read_heidenhain

            out.forward = read_heidenhain(folder, sign)
            if bidir:
                out.reverse = _heidenhain_reverse(folder, sign, out.forward)
        elif fmt == "linuxcnc":
            from volcal.compensate.linuxcnc import read_linuxcnc

            ct = _linuxcnc_type(folder, manifest)
            out.forward = read_linuxcnc(folder, sign, ct, "+")
            rev = read_linuxcnc(folder, sign, ct, "-")
            if any(not np.array_equal(a.values, b.values)
                   for a, b in zip(out.forward, rev, strict=True)):
                out.reverse = rev
        elif fmt == "csv":
            from volcal.compensate.generic import CSV_FILE, read_generic

            out.forward = read_generic(folder / CSV_FILE)
        elif fmt == "isg":
            from volcal.compensate.volumetric import ISG_FILE, read_isg

            out.volumetric, out.volumetric_sign = read_isg(folder / ISG_FILE)
        elif fmt == "grid":
            from volcal.compensate.volumetric import GRID_FILE

            out.grid_axes, out.grid_values, out.volumetric_sign = _grid_tables(
                folder / GRID_FILE)
        else:
            raise VolcalInputError(f"controller_format = {fmt!r}: volcal cannot read these "
                                   "tables back (expected fanuc, siemens, heidenhain, "
                                   "linuxcnc, csv, isg or grid)", folder,
                                   column="controller_format")
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read the {fmt} tables ({exc.__class__.__name__}: "
                               f"{exc})", folder) from None
    except (ValueError, IndexError, KeyError) as exc:
        if isinstance(exc, VolcalInputError):
            raise
        raise VolcalInputError(f"damaged {fmt} tables ({exc.__class__.__name__}: {exc})",
                               folder) from None
    for t in out.forward + (out.reverse or []):
        if t.positions.size < 1 or np.any(np.diff(t.positions) <= 0):
            raise VolcalInputError(f"table {t.name}: positions must increase strictly",
                                   folder)
    return out


def _heidenhain_reverse(folder: Path, sign: str, forward: list[AxisTable]
                        ) -> list[AxisTable]:
    """The ``BACKLASH`` column of each ``.COM`` table that has one; the axis column else."""
    from volcal.compensate.heidenhain import CMA_FILE, RESOLUTION_UM, _table
    from volcal.model.names import AXES

    head, rows = _table(folder / CMA_FILE)
    active = [r for r in rows if r[head.index("ACTIVE")] == "*"][0]
    out = []
    for t in forward:
        com = active[head.index(AXES[t.input_axis])]
        h, data = _table(folder / com)
        if "BACKLASH" not in h:
            out.append(t)
            continue
        j = h.index("BACKLASH")
        try:
            v = np.array([float(r[j]) for r in data]) * 1000.0
        except (ValueError, IndexError):
            raise VolcalInputError("bad number in column BACKLASH", folder / com) from None
        out.append(AxisTable(t.input_axis, t.output_axis, t.positions, v, sign, RESOLUTION_UM))
    return out
