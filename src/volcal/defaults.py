"""The defaults shared by the command line and the Python API, in one place.

Every option that ``volcal <command>`` and :class:`volcal.Calibration` (or a library
function it calls) both take gets its default from here, so that the two cannot drift
apart; ``tests/test_defaults_parity.py`` reads the typer commands' defaults by
introspection and compares them with the Python signatures.

The compensation sign has no default value of its own: ``None`` means *the controller's
own convention* (:data:`volcal.compensate.formats.FORMAT_INFO`, e.g. ``'correction'`` =
-error for Fanuc and LinuxCNC). A table in the wrong sign doubles the machine's error,
so neither the command line nor Python ever picks a sign for the user, and the format is
always named (no default format).
"""

from __future__ import annotations

# -- plan (volcal plan, Calibration.plan) ---------------------------------------------------
CHAIN = "XYFZ"
"""Kinematic chain code, workpiece to tool (F = frame)."""
PLAN_STEPS = 10
"""Increments per test."""
PLAN_TESTS: tuple[str, ...] = ("step-diagonal", "diagonal", "linear")
"""Planned tests."""
PLAN_RUNS = 5
"""Bidirectional runs per linear test (ISO 230-2)."""
PLAN_NAME = "VMC-1"
"""Machine name of a planned session."""
PLAN_STEP_ORDERS: tuple[str, ...] = ("xyz",)
"""Axis orders of the step diagonals."""
PLAN_TOOL_OFFSET_MM: tuple[float, float, float] = (0.0, 0.0, 0.0)
"""Target point on the tool [mm]."""
PLAN_STEP_TARGET = "flat_mirror"
"""Target of the step diagonals."""
PLAN_ABBE_OFFSET_MM = 150.0
"""Target offset from the spindle of the Abbe lines no machine move can offset [mm]."""
ML_GRID: tuple[int, int, int] = (9, 7, 6)
"""Multilateration: grid points along x, y, z."""
ML_STATIONS = 4
"""Multilateration: number of default stations."""
ML_TOOL_OFFSETS_MM: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, -100.0),
                                                               (100.0, 100.0, -100.0))
"""Multilateration: reflector offsets on the tool [mm]."""

# -- simulate (volcal simulate, Calibration.simulate) --------------------------------------
SIM_SEED = 0
"""Seed of the virtual machine and of the reading noise."""
SIM_NOISE_UM = 0.5
"""Reading noise, standard deviation [um]."""
SIM_MIRROR_URAD = 20.0
"""Residual set-up misalignment of the optics, standard deviation [urad]."""
SIM_DRIFT_UM_PER_H = 0.0
"""Linear drift of the readings [um/h]."""
SIM_REVERSAL_UM = 0.0
"""Largest reversal (backlash) of a random machine's axes [um]."""

# -- identify / advise ----------------------------------------------------------------------
ROLL = "estimate"
"""Rolls EAX, EBY, ECZ: ``'estimate'`` or ``'zero'``."""
PRIOR = "smooth"
"""Prior of the identification: ``'smooth'`` (Bayesian) or ``'none'`` (min-norm LS)."""
MAX_NODES = 41
"""Nodes per axis at most (problem size)."""
MONTE_CARLO = 0
"""Monte Carlo trials of the noise propagation (GUM S1); 0 = off."""
ADVISE_TOP = 10
"""Candidate poses and sphere positions ``advise`` lists for a 5-axis design."""

# -- evaluate / report ----------------------------------------------------------------------
EDITION = "2014"
"""ISO 230-2 edition."""
DECISION_RULE = "simple"
"""Decision rule of a tolerance verdict: ``'simple'`` (pass when the value is at most the
tolerance) or ``'guarded'`` (:mod:`volcal.standards.decision`, ILAC-G8:09/2019)."""

# -- compensate (volcal compensate, Calibration.compensate) --------------------------------
COMP_SIGN: str | None = None
"""``None``: each controller's own sign convention (never a fixed sign)."""
COMP_SPACING_MM = 20.0
"""Distance between compensation points [mm]."""
COMP_UNIT_UM = 1.0
"""Fanuc detection unit [um]."""
COMP_MAGNIFICATION = 1
"""Fanuc magnification (parameter 3623)."""
COMP_MAX_INCREMENT = 7
"""Fanuc largest value per point."""
COMP_FANUC_SERIES = "30i"
"""Fanuc parameter syntax."""
COMP_LINUXCNC_TYPE = 1
"""LinuxCNC ``COMP_FILE_TYPE``."""
COMP_SQUARENESS = True
"""Siemens CEC tables carry the squareness terms."""
COMP_ROTARY_SPACING_DEG = 5.0
"""Distance between the points of a rotary axis' Siemens and Fanuc tables [deg]
(:class:`volcal.compensate.rotary.RotaryOptions`)."""

# -- program (volcal program, Calibration.program) -----------------------------------------
PROG_DWELL_S = 4.0
"""Dwell at each reading pose [s]."""
PROG_FEED = 2000.0
"""Feed of every move [mm/min]."""
PROG_OVERRUN_MM = 5.0
"""ISO 230-2 overrun before reversals [mm]."""
PROG_DECIMALS = 3
"""Decimals of the coordinates [mm]."""
PROG_SAFE_Z_MM = 0.0
"""Z of the first retract in machine coordinates [mm]."""
PROG_FIRST_NUMBER = 1000
"""Fanuc program number (O word) of the first program."""

# -- import (volcal import, Calibration.import_) -------------------------------------------
IMPORT_UNITS = "auto"
"""Unit of the target/reading columns."""
IMPORT_DEVIATION_UNITS = "auto"
"""Unit of the deviation columns."""
IMPORT_OPTICS = "retroreflector"
"""Optics on the tool of a new linear measurement."""
IMPORT_CHAIN = "XYFZ"
"""Chain of a session created by an import."""
IMPORT_NAME = "machine"
"""Machine name of a session created by an import."""
IMPORT_SIGN = "+"
"""Direct optics: ``'+'`` (the tool side relative to the workpiece side) or ``'-'``."""
IMPORT_DWELL_S = 4.0
"""Renishaw dynamic capture: the part program's dwell at each target [s]."""

# -- predict (volcal predict) ---------------------------------------------------------------
TOOL_OFFSET_MM: tuple[float, float, float] = (0.0, 0.0, 0.0)
"""Tool offset x, y, z of a prediction or a planned target [mm]."""

# -- capture (volcal capture) --------------------------------------------------------------
CAPTURE_WINDOW_MM = 0.010
"""Target window of the trigger rule: every axis within this distance of the target [mm]."""
CAPTURE_WINDOW_DEG = 0.005
"""Target window of a rotary test: the rotary axis within this angle of the target [deg]."""
CAPTURE_STABLE_S = 1.0
"""Time both signals must be stable before a point is accepted [s]."""
CAPTURE_K_SIGMA = 4.0
"""Stability threshold of the trigger rule, in standard errors of the noise."""
CAPTURE_LASER_NOISE = 0.01
"""Floor of the laser's noise standard deviation [um or urad] (its resolution)."""
CAPTURE_CONTROL_NOISE_MM = 0.0005
"""Floor of the control position's noise standard deviation [mm]."""
CAPTURE_MAX_GAP_S = 0.5
"""Longest polling gap tolerated inside a stable window [s]."""
CAPTURE_POLL_S = 0.02
"""Pause between two polls of the sources [s]."""
