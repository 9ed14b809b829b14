"""Environment compensation of laser readings: air refractive index, material expansion, drift.

Modules
-------
refractive
    Refractive index of air (modified Edlén, Ciddor).
materials
    Thermal expansion coefficients and normalisation to 20 degC (ISO 1).
compensation
    Wavelength and material compensation of raw laser readings.
drift
    Drift check from repeated readings at the start point.
apply
    Compensation of a session :class:`~volcal.session.format.Measurement` with raw readings.
"""

from volcal.environment.compensation import compensate_readings
from volcal.environment.drift import DriftCheck, drift_check
from volcal.environment.materials import EXPANSION_PPM_PER_K, expansion_coefficient
from volcal.environment.refractive import ciddor, edlen, refractive_index

__all__ = [
    "EXPANSION_PPM_PER_K",
    "DriftCheck",
    "ciddor",
    "compensate_readings",
    "drift_check",
    "edlen",
    "expansion_coefficient",
    "refractive_index",
]
