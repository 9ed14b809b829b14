"""Which coordinates a probe_sphere test's control programs and logs: joints or the table.

``control_kinematics`` (a key of the probe_sphere entry, ``docs/formats.md``):

* ``"joints"`` (default): the control's X Y Z are the linear axes' positions (no tool centre
  point transformation, e.g. LinuxCNC with ``trivkins``): the part program moves to the
  centres the configured kinematics predict and the control reports machine coordinates;
* ``"tcp"``: the control maps the program's X Y Z into the rotary table's coordinates
  through its configured kinematics (LinuxCNC's ``xyzac-trt-kins``/``xyzbc-trt-kins``, a
  tool centre point control): the part program probes the sphere where it sits on the
  table, the same point at every pose, and the probe log holds table coordinates; volcal
  turns the fitted centres back into machine coordinates through the configured kinematics
  (the test's ``pivot_mm``, which must be the control's at the probing).
"""

from __future__ import annotations

from typing import Any

from volcal.errors import VolcalInputError

__all__ = ["CONTROL_KINEMATICS", "control_kinematics"]

CONTROL_KINEMATICS = ("joints", "tcp")
"""The values of ``control_kinematics``."""


def control_kinematics(m: Any) -> str:
    """The test's ``control_kinematics`` (``'joints'`` or ``'tcp'``).

    Parameters
    ----------
    m : Measurement
        A probe_sphere measurement.

    Raises
    ------
    VolcalInputError
        Another value, naming the key.
    """
    v = m.meta.get("control_kinematics", "joints")
    if v not in CONTROL_KINEMATICS:
        raise VolcalInputError(f"control_kinematics {v!r}: expected one of "
                               f"{', '.join(CONTROL_KINEMATICS)}", "session.toml", None,
                               f"measurements.{m.id}.control_kinematics")
    return str(v)
