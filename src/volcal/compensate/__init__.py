"""Compensation tables for CNC controllers, written from an identified error model.

``tables`` resamples the model onto a controller's uniform grid with an explicit sign
(error or correction) and checks the limits; one module per controller family writes
and reads its files (``fanuc``, ``siemens``, ``heidenhain``, ``generic``) and
``volumetric`` writes the whole model (ISG/Beckhoff-style blocks, 3-D error grid).
``formats`` is the registry the CLI uses. See ``docs/compensation.md``.
"""

from volcal.compensate.formats import FORMATS, CompensationOptions, write_compensation
from volcal.compensate.tables import AxisTable, axis_grid, sign_factor

__all__ = ["FORMATS", "AxisTable", "CompensationOptions", "axis_grid", "sign_factor",
           "write_compensation"]
