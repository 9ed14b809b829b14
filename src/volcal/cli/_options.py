"""The command line's name of every step parameter, in one table.

The step functions (:mod:`volcal.steps`) name their parameters in their errors
(:class:`~volcal.errors.ParameterError`); the command line prints them with its own
option names from :data:`OPTIONS`, so that a user at the command line reads
``--noise-um`` where Python reads ``noise_um``. A parameter missing from the table is
printed as ``--`` + its name with ``-`` for ``_`` (the typer spelling).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from volcal.errors import ParameterError

P = ParamSpec("P")
R = TypeVar("R")

#: Python parameter -> command-line option, where typer's spelling is not the option.
RENAMED: dict[str, str] = {
    "mirror_misalignment_urad": "--mirror-urad",
    "multilateration": "--grid/--stations/--tool-offsets",
    "csv_file": "FILE",
    "session": "--session",
    "output": "--output",
    "location_tolerance": "--location-tolerance-um",
    "settings": "--estimator-settings",
}

#: Every parameter the command line names in an error of a step.
OPTIONS: dict[str, str] = {
    name: RENAMED.get(name, "--" + name.replace("_", "-")) for name in (
        # plan
        "travel", "chain", "steps", "tests", "runs", "name", "step_orders", "tool_offset",
        "iso_spacing", "step_target", "overrun_mm", "abbe_offset_mm", "multilateration",
        "output", "add", "replace", "targets", "rotary_axes",
        # simulate
        "seed", "noise_um", "mirror_misalignment_urad", "drift_um_per_h", "reversal_um",
        "machine", "overwrite", "budget", "compensation",
        # evaluate, verdict, report
        "decision_rule", "guard_band_um", "tolerance_um",
        # program
        "dialect", "dwell_s", "feed", "decimals", "safe_z_mm", "first_number",
        # import
        "csv_file", "session", "map", "axis", "id", "measurement", "line_mm", "units",
        "deviation_units", "optics", "sign", "slope_removed",
        # identify, advise
        "prior", "roll", "known", "known_u", "monte_carlo", "drift", "measurements",
        "max_nodes", "robust", "candidates", "top", "settings",
        # predict
        "points", "force",
        # compensate
        "format", "spacing", "max_points", "reference_mm", "unit_um", "magnification",
        "max_increment", "fanuc_series", "linuxcnc_type", "squareness", "rotary_spacing",
        # locate
        "model", "prior_u", "linuxcnc_hal", "z_rot_point_mm", "siemens_tcarr", "tool_carrier",
        "isg_kinematics",
        # report
        "location_tolerance_um", "location_tolerance",
        # capture
        "control", "laser", "programs", "window_mm", "stable_s", "k_sigma", "laser_noise",
        "control_noise_mm", "max_gap_s", "poll_s", "timeout_s", "speed", "window_deg", "again",
    )
}


def cli_spelling(func: Callable[P, R]) -> Callable[P, R]:
    """Wrap a command so that a step's :class:`ParameterError` names the CLI's options.

    Parameters
    ----------
    func : callable
        The typer command; its signature is kept (typer reads it through ``__wrapped__``).

    Returns
    -------
    callable
    """
    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except ParameterError as exc:
            raise exc.spelled(OPTIONS) from None

    return wrapper
