"""Volumetric error map: arrows on slices of the work zone, coloured by vector length.

The volumetric error is the actual minus the commanded position of the tool point in
machine axes [um] (ISO 230-1:2012, 3.1.4; first-order model of Soons, seed 004, eq. 1).
Each panel is a slice ``z = const`` of the work zone; the arrows show the in-plane
components ``(e_x, e_y)`` magnified, the colour the full length ``|e|`` including ``e_z``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.plot._figure import new_figure

__all__ = ["VolumetricMap", "volumetric_map", "volumetric_map_plot"]


@dataclass(frozen=True)
class VolumetricMap:
    """The volumetric error on a grid of slices.

    Attributes
    ----------
    x, y : ndarray, shape (nx,), (ny,)
        Grid lines [mm].
    z : ndarray, shape (nz,)
        Heights of the slices [mm].
    error : ndarray, shape (nz, ny, nx, 3)
        Volumetric error e_x, e_y, e_z [um].
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z: NDArray[np.float64]
    error: NDArray[np.float64]

    @property
    def length(self) -> NDArray[np.float64]:
        """Length of the error vector, shape (nz, ny, nx) [um]."""
        return np.linalg.norm(self.error, axis=-1)


def volumetric_map(errors: MachineErrors, travel: ArrayLike | None = None, nx: int = 9,
                   ny: int = 7, z: Sequence[float] | None = None,
                   tool_offset: ArrayLike | None = None) -> VolumetricMap:
    """Evaluate the first-order volumetric error on slices of the work zone.

    Parameters
    ----------
    errors : MachineErrors
        The machine.
    travel : array_like, shape (3, 2), optional
        Work zone [mm]; the machine's node range by default.
    nx, ny : int
        Grid lines in X and Y.
    z : sequence of float, optional
        Slice heights [mm]; bottom, middle and top of the Z travel by default.
    tool_offset : array_like, shape (3,), optional
        Tool offset [mm].

    Returns
    -------
    VolumetricMap
    """
    t = errors.travel if travel is None else np.asarray(travel, dtype=float).reshape(3, 2)
    x = np.linspace(t[0, 0], t[0, 1], nx)
    y = np.linspace(t[1, 0], t[1, 1], ny)
    zs = np.linspace(t[2, 0], t[2, 1], 3) if z is None else np.asarray(z, dtype=float)
    Z, Y, X = np.meshgrid(zs, y, x, indexing="ij")
    q = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    e = volumetric_error(errors, q, tool_offset)
    return VolumetricMap(x, y, zs, e.reshape(zs.size, y.size, x.size, 3))


def volumetric_map_plot(vmap: VolumetricMap, title: str | None = None,
                        fig: Figure | None = None) -> Figure:
    """Arrows of the in-plane volumetric error on each slice, coloured by ``|e|``.

    Parameters
    ----------
    vmap : VolumetricMap
        Result of :func:`volumetric_map`.
    title : str, optional
        Figure title.
    fig : Figure, optional
        Figure to draw into.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per slice, a shared colour bar ``|e| [µm]`` and an arrow key; the
        arrows are magnified by one common factor (stated in the title of each panel).
    """
    nz = vmap.z.size
    fig = fig or new_figure(4.6 * nz + 1.0, 4.4)
    axs = fig.subplots(1, nz, squeeze=False)[0]
    length = vmap.length
    planar = np.hypot(vmap.error[..., 0], vmap.error[..., 1])
    spacing = min(np.ptp(vmap.x) / max(vmap.x.size - 1, 1),
                  np.ptp(vmap.y) / max(vmap.y.size - 1, 1))
    peak = float(planar.max())
    mag = 0.9 * spacing / peak if peak > 0 else 1.0  # [mm per um]
    vmax = float(length.max()) if length.max() > 0 else 1.0
    X, Y = np.meshgrid(vmap.x, vmap.y)
    quiv = None
    for i, ax in enumerate(axs):
        quiv = ax.quiver(X, Y, vmap.error[i, ..., 0], vmap.error[i, ..., 1], length[i],
                         cmap="viridis", clim=(0.0, vmax), angles="xy", scale_units="xy",
                         scale=1.0 / mag, width=0.006, gid=f"slice {i}")
        ax.set_aspect("equal")
        pad = 0.6 * spacing
        ax.set_xlim(vmap.x[0] - pad, vmap.x[-1] + pad)
        ax.set_ylim(vmap.y[0] - pad, vmap.y[-1] + pad)
        ax.set_title(f"z = {vmap.z[i]:g} mm", fontsize="medium")
        ax.set_xlabel("X [mm]")
        if i == 0:
            ax.set_ylabel("Y [mm]")
    assert quiv is not None
    key = 10.0 ** np.floor(np.log10(peak)) if peak > 0 else 1.0
    axs[-1].quiverkey(quiv, 0.97, 1.03, key, f"{key:g} µm", labelpos="W", coordinates="axes",
                      fontproperties={"size": 8})
    fig.colorbar(quiv, ax=list(axs), label="|e| [µm]", shrink=0.9)
    fig.suptitle(title or f"volumetric error, arrows (e_x, e_y) x {mag * 1000:.0f}, "
                 f"colour |e|; max |e| = {vmax:.1f} µm")
    return fig
