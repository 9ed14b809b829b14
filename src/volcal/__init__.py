"""volcal: open laser-interferometer calibration of machine tools and CMMs.

The package follows one direction of flow::

    plan -> program -> measure/simulate -> identify -> evaluate -> compensate -> report

The kinematic model (:mod:`volcal.model`) is the shared core. Plotting lives in
:mod:`volcal.plot` and is never imported by the analysis code.
"""

from volcal.errors import VolcalInputError

__version__ = "0.1.0"

__all__ = ["VolcalInputError", "__version__"]
