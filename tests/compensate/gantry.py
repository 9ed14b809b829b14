"""A 1200 x 800 x 600 mm gantry (FXYZ) whose Y pitch table makes a line at another Abbe
offset worse: shared by the compensation tests.

Hidden truth: EYY(y) = 0.01 y [um] (10 um/m scale error) and the tilt EAY(y) = y / 60 urad.
On FXYZ the lever of Y's tilts is the tool offset plus z; the positioning error of Y on a
line at height z is EYY - EAY * z * 1e-3 (docs/conventions.md), so on the line at
z = 600 mm the two cancel: that line is nearly perfect before compensation, and a pitch
table that removes EYY (valid on Y's reference line z = 0) leaves -0.01 y there: A grows
from the noise to about 8 um.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.model.errorfunctions import MachineErrors
from volcal.plan.planner import plan_session
from volcal.session.errortable import write_error_table
from volcal.session.format import read_session, write_session

GANTRY_TRAVEL = np.array([[0.0, 1200.0], [0.0, 800.0], [0.0, 600.0]])
NAME = "FXYZ-1200"


def gantry_errors(scale_um_per_mm: float = 0.01, name: str = NAME) -> MachineErrors:
    """The gantry's errors: EYY = scale * y, EAY = y / 60 urad, nothing else."""
    y = np.linspace(0.0, 800.0, 9)
    vy = np.zeros((9, 6))
    vy[:, 1] = scale_um_per_mm * y
    vy[:, 3] = y / 60.0
    zero = np.zeros((2, 6))
    return MachineErrors("FXYZ", [GANTRY_TRAVEL[0], y, GANTRY_TRAVEL[2]], [zero, vy, zero],
                         name=name)


def write_gantry(folder: Path, serial: str | None = None) -> tuple[Path, Path]:
    """Plan (3 Abbe lines per axis, 3 bidirectional runs), simulate (noise 0.1 um), write.

    Returns
    -------
    session : Path
        The session folder.
    model : Path
        The truth as an error table (``volcal-errors/1``), used as the model.
    """
    e = gantry_errors()
    s = plan_session(GANTRY_TRAVEL, "FXYZ", 8, ("linear",), 3, name=NAME)
    if serial is not None:
        s.meta.update({"make": "Gantry Works", "serial": serial})
    opt = SimulationOptions(noise_um=0.1, mirror_misalignment_urad=0.0, seed=3)
    setups = simulate_session(s, e, opt)
    write_session(s, folder / "S", truth_files(e, setups, opt))
    write_error_table(e, folder / "model.csv")
    return folder / "S", folder / "model.csv"


def read(folder: Path):
    """The session as volcal reads it."""
    return read_session(folder)
