"""Step ``locate``: the location errors of the rotary axes from probe-on-sphere tests.

``volcal locate SESSION`` reads the session's ``probe_sphere`` measurements (one chain),
identifies the location errors the poses determine with their uncertainty
(:func:`volcal.identify.location.identify_location`) and says in plain words which errors
the design cannot separate and what the determined ones stand for (``docs/fiveaxis.md``).
The linear axes' errors are those of ``model`` (a ``volcal identify`` model file, or an
error table such as a simulation's ``truth/machine.csv``), else taken as perfect.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import ParameterError, VolcalInputError

if TYPE_CHECKING:
    from volcal.identify.location import LocationResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session

__all__ = ["LOCATE_FORMAT", "Located", "locate"]

LOCATE_FORMAT = "volcal-location/1"
"""``format`` of the JSON ``volcal locate --json`` writes."""
COVERAGE_K = 2.0
"""Coverage factor of the expanded uncertainty U = k u."""


@dataclass(frozen=True)
class Located:
    """What :func:`locate` computed.

    Attributes
    ----------
    result : LocationResult
        Estimate, uncertainty, identifiability, scatter before and after.
    chain : str
        The 5-axis chain.
    measurements : tuple of str
        The probe_sphere measurements used.
    messages : tuple of str
        The identifiability report in plain words, then the scatter.
    blocks : tuple of SphereReadings
        The readings used.
    """

    result: LocationResult
    chain: str
    measurements: tuple[str, ...]
    messages: tuple[str, ...] = field(default_factory=tuple)
    blocks: tuple[Any, ...] = field(default_factory=tuple)

    def to_json(self) -> dict[str, Any]:
        """The document of ``volcal locate --json`` (``docs/formats.md``)."""
        r = self.result
        rows = []
        for row in r.to_rows():
            u = float(row["u"])  # type: ignore[arg-type]
            rows.append({**row, "U": None if math.isnan(u) else COVERAGE_K * u,
                         "u": None if math.isnan(u) else u})
        return {
            "format": LOCATE_FORMAT, "chain": self.chain, "measurements": list(self.measurements),
            "coverage_factor": COVERAGE_K, "location_errors": rows,
            "determined": list(r.identifiability.free),
            "redundant": {g: r.identifiability.combinations[g]
                          for g in r.identifiability.fixed},
            "nuisances": r.nuisances, "rms_before_um": r.rms_before_um,
            "rms_after_um": r.rms_after_um, "chi2": r.chi2, "dof": r.dof,
            "messages": list(self.messages),
        }

    def linuxcnc_trt(self, z_rot_point_mm: float | None = None) -> Any:
        """LinuxCNC's trt kinematics pins of the result and the residual they leave.

        Parameters
        ----------
        z_rot_point_mm : float, optional
            ``z-rot-point`` to keep (default the C pivot's z).

        Returns
        -------
        volcal.compensate.linuxcnc_trt.TrtExport
        """
        from volcal.compensate.linuxcnc_trt import trt_export
        from volcal.identify.location import identify_location
        from volcal.model.names import info

        # the best lines without tilt: the fit with the orientations and zeros held at zero
        m = self.result.machine
        hold = [n for n in self.result.identifiability.names if info(n).kind != "position"]
        nominal = m.with_location(np.zeros(len(self.result.identifiability.names)))
        control = identify_location(nominal, list(self.blocks), hold=hold).machine
        spheres: dict[str, Any] = {}
        for k, v in self.result.nuisances.items():
            sid, _, ax = k.rpartition(":")
            if ax in ("sx", "sy", "sz"):
                spheres.setdefault(sid, [0.0, 0.0, 0.0])["xyz".index(ax[1])] = v
        return trt_export(m, self.blocks, spheres, configured=nominal,
                          z_rot_point_mm=z_rot_point_mm, control=control)

    def siemens_tcarr(self, carrier: int = 1) -> Any:
        """The Siemens swivel data record (``$TC_CARR``) of the result and its residual.

        Parameters
        ----------
        carrier : int
            Number of the record.

        Returns
        -------
        volcal.compensate.siemens_tcarr.TcarrExport
        """
        from volcal.compensate.siemens_tcarr import tcarr_export

        m = self.result.machine
        spheres: dict[str, Any] = {}
        for k, v in self.result.nuisances.items():
            sid, _, ax = k.rpartition(":")
            if ax in ("sx", "sy", "sz"):
                spheres.setdefault(sid, [0.0, 0.0, 0.0])["xyz".index(ax[1])] = v
        nominal = m.with_location(np.zeros(len(self.result.identifiability.names)))
        return tcarr_export(m, self.blocks, spheres, nominal, carrier)

    def isg_location(self) -> Any:
        """The ISG/Beckhoff volumetric compensation's location errors and their residual.

        Returns
        -------
        volcal.compensate.isg_location.IsgLocationExport
        """
        from volcal.compensate.isg_location import isg_location_export

        m = self.result.machine
        spheres: dict[str, Any] = {}
        for k, v in self.result.nuisances.items():
            sid, _, ax = k.rpartition(":")
            if ax in ("sx", "sy", "sz"):
                spheres.setdefault(sid, [0.0, 0.0, 0.0])["xyz".index(ax[1])] = v
        nominal = m.with_location(np.zeros(len(self.result.identifiability.names)))
        return isg_location_export(m, self.blocks, spheres, nominal,
                                   list(self.result.identifiability.fixed))

    def to_text(self) -> str:
        """The table and the report as ``volcal locate`` prints them."""
        lines = [f"chain {self.chain}: {len(self.measurements)} probe_sphere test(s)",
                 f"{'error':6} {'value':>10} {'U (k=2)':>9}  unit  meaning"]
        for row in self.result.to_rows():
            u = float(row["u"])  # type: ignore[arg-type]
            val = f"{float(row['value']):10.2f}" if not math.isnan(u) else f"{'-':>10}"  # type: ignore[arg-type]
            U = f"{COVERAGE_K * u:9.2f}" if not math.isnan(u) else f"{'redundant':>9}"
            lines.append(f"{row['name']:6} {val} {U}  {row['unit']:4}  {row['meaning']}")
        return "\n".join(lines + [f"- {m}" for m in self.messages]) + "\n"


def _linear_model(model: Any):
    if model is None or hasattr(model, "chain_obj"):  # None or a MachineErrors
        return model
    p = Path(model)
    if p.suffix.lower() == ".json":
        from volcal.identify.modelfile import load_model_errors

        return load_model_errors(p)
    from volcal.session.errortable import read_error_table

    return read_error_table(p)


def locate(session: str | Path | Session, *, model: str | Path | MachineErrors | None = None,
           measurements: list[str] | None = None, prior_u: float | None = None) -> Located:
    """Identify the rotary axes' location errors from a session's probe_sphere tests.

    Parameters
    ----------
    session : str, Path or Session
        The session folder (or a read session).
    model : str, Path or MachineErrors, optional
        The linear axes' errors: a model file (``MODEL.json``), an error table
        (``machine.csv``/``.toml``) or the errors themselves; None: perfect linear axes.
    measurements : list of str, optional
        Ids of the probe_sphere measurements to use (default all).
    prior_u : float, optional
        Standard deviation of a zero-mean Gaussian prior on each determined location error
        [um for positions, urad for angles]; None: none (least squares).

    Returns
    -------
    Located

    Raises
    ------
    VolcalInputError
        No probe_sphere test, tests of different chains or pivots, an unmeasured test.
    """
    from volcal.identify.location import identify_location, separation_advice
    from volcal.kinds.probe_sphere import five_axis_machine, sphere_readings
    from volcal.session.format import Session, read_session

    if prior_u is not None and not (math.isfinite(prior_u) and prior_u > 0):
        raise ParameterError(f"{{prior_u=}}{prior_u}: expected a positive standard deviation "
                             "[um or urad]")
    s = session if isinstance(session, Session) else read_session(session)
    ms = [m for m in s.measurements if m.kind == "probe_sphere"]
    if measurements is not None:
        unknown = sorted(set(measurements) - {m.id for m in ms})
        if unknown:
            raise ParameterError(f"{{measurements=}}{unknown[0]!r}: no probe_sphere test of "
                                 "that id in the session")
        ms = [m for m in ms if m.id in measurements]
    if not ms:
        raise VolcalInputError("the session has no probe_sphere test (docs/fiveaxis.md)")
    for m in ms:
        if m.deviation is None:
            raise VolcalInputError(f"probe_sphere test {m.id!r} is not measured: its CSV has "
                                   "no reported centres (x_mm, y_mm, z_mm)")
    ref = ms[0].meta
    for m in ms[1:]:
        if m.meta.get("chain") != ref.get("chain") or m.meta.get("pivot_mm") != ref.get(
                "pivot_mm"):
            raise VolcalInputError(f"probe_sphere tests {ms[0].id!r} and {m.id!r} give another "
                                   "chain or pivots: locate one machine configuration at a time")
    linear = _linear_model(model)
    nominal = five_axis_machine(ms[0], linear)
    blocks = [sphere_readings(m) for m in ms]
    res = identify_location(nominal, blocks, prior_u=prior_u)
    msgs = list(res.identifiability.messages) + separation_advice(nominal, blocks) + [
        f"Scatter of the readings: RMS {res.rms_before_um:.2f} um with the configured "
        f"kinematics, {res.rms_after_um:.2f} um with the identified location errors "
        f"(chi-square {res.chi2:.1f} on {res.dof} degrees of freedom)."]
    return Located(res, nominal.chain_obj.code, tuple(m.id for m in ms), tuple(msgs),
                   tuple(blocks))


def located_json(located: Located) -> str:
    """The JSON text of ``volcal locate --json``.

    Parameters
    ----------
    located : Located
        The step's result.
    """
    return json.dumps(located.to_json(), indent=2, allow_nan=False) + "\n"
