"""Step ``locate``: the location errors of the rotary axes from probe-on-sphere and R-test tests.

``volcal locate SESSION`` reads the session's ``probe_sphere`` and ``r_test`` measurements
(one chain, either kind or both),
identifies the location errors the poses determine with their uncertainty
(:func:`volcal.identify.location.identify_location`) and says in plain words which errors
the design cannot separate and what the determined ones stand for (``docs/fiveaxis.md``).
The linear axes' errors are those of ``model`` (a ``volcal identify`` model file, or an
error table such as a simulation's ``truth/machine.csv``), else taken as perfect; a model
file with its covariance enters as a prior with its uncertainty
(:mod:`volcal.identify.location_linear`): the location errors' U then includes the linear
model's.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import ParameterError, VolcalInputError
from volcal.io.sniff import is_model_file, model_path

if TYPE_CHECKING:
    from volcal.identify.location import LocationResult
    from volcal.identify.result import IdentificationResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session

__all__ = ["LOCATE_FORMAT", "Located", "locate"]

LOCATE_FORMAT = "volcal-location/1"
"""``format`` of the JSON ``volcal locate --json`` writes."""
COVERAGE_K = 2.0
"""Coverage factor of the expanded uncertainty U = k u."""
SPHERE_KINDS = ("probe_sphere", "r_test")
"""The kinds whose readings locate the rotary axes."""


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
    kinds : tuple of str
        The kind of each measurement used (``probe_sphere``, ``r_test``).
    """

    result: LocationResult
    chain: str
    measurements: tuple[str, ...]
    messages: tuple[str, ...] = field(default_factory=tuple)
    blocks: tuple[Any, ...] = field(default_factory=tuple)
    kinds: tuple[str, ...] = field(default_factory=tuple)

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
            "kinds": list(self.kinds),
            "linear_model": None if r.linear is None else r.linear.to_json(),
            "u_without_linear": (None if r.u_without_linear is None
                                 else dict(r.u_without_linear)),
            "u_without_undetermined": (None if r.u_without_undetermined is None
                                       else dict(r.u_without_undetermined)),
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

        if z_rot_point_mm is not None and not (
                isinstance(z_rot_point_mm, int | float) and np.isfinite(z_rot_point_mm)):
            raise ParameterError(f"{{z_rot_point_mm=}}{z_rot_point_mm!r}: expected a finite "
                                 "number [mm]")

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

        if isinstance(carrier, bool) or not isinstance(carrier, int) or carrier < 1:
            raise ParameterError(f"{{tool_carrier=}}{carrier!r}: expected a record number 1, "
                                 "2, ...")
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
        kinds = self.kinds or ("probe_sphere",) * len(self.measurements)
        counts = ", ".join(f"{kinds.count(k)} {k} test(s)" for k in dict.fromkeys(kinds))
        lines = [f"chain {self.chain}: {counts}",
                 f"{'error':6} {'value':>10} {'U (k=2)':>9}  unit  meaning"]
        for row in self.result.to_rows():
            u = float(row["u"])  # type: ignore[arg-type]
            val = f"{float(row['value']):10.2f}" if not math.isnan(u) else f"{'-':>10}"  # type: ignore[arg-type]
            U = f"{COVERAGE_K * u:9.2f}" if not math.isnan(u) else f"{'redundant':>9}"
            lines.append(f"{row['name']:6} {val} {U}  {row['unit']:4}  {row['meaning']}")
        return "\n".join(lines + [f"- {m}" for m in self.messages]) + "\n"


def _undetermined_share(res: Any) -> list[str]:
    """The share of the location errors' U that rests on the undetermined functions' prior."""
    ud = res.u_without_undetermined
    if not ud:
        return []
    share = {n: 1.0 - (ud[n] / res.u[n]) ** 2 for n in ud if res.u[n] > 0}
    if not share:
        return []
    from volcal.model.names import info

    worst = max(share, key=lambda n: share[n])
    unit = info(worst).unit
    return [f"The undetermined functions' prior carries up to {100 * share[worst]:.0f} % of a "
            f"location error's variance ({worst}: u {res.u[worst]:.3g} {unit}, "
            f"{ud[worst]:.3g} {unit} with them taken as known; per error in the JSON, "
            "u_without_undetermined): that part of U is an assumption about this machine."]


def _linear_model(model: Any):
    """None, MachineErrors (an error table) or IdentificationResult (a model file)."""
    if model is None or hasattr(model, "chain_obj") or hasattr(model, "layout"):
        return model
    p = model_path(model)  # a folder (a session's) said for what it is, as every reader does
    if is_model_file(p):
        from volcal.identify.modelfile import load_model

        return load_model(p)
    from volcal.session.errortable import read_error_table

    return read_error_table(p)


def _one_configuration(ms: list[Any]) -> None:
    """Refuse sphere tests of several machine configurations (chain or pivots), naming them.

    Each configuration's test ids are listed with its chain and pivots, so that the
    message says what to pass as ``measurements``.
    """
    groups: dict[tuple[str, str], list[str]] = {}  # (chain, exact pivots) -> test ids
    shown: dict[tuple[str, str], str] = {}
    for m in ms:
        piv = sorted((m.meta.get("pivot_mm") or {}).items())
        key = (str(m.meta.get("chain")), repr([(a, [float(v) for v in p]) for a, p in piv]))
        groups.setdefault(key, []).append(m.id)
        shown[key] = " ".join(f"{a.upper()} ({', '.join(f'{float(v):g}' for v in p)})"
                              for a, p in piv) or "none"
    if len(groups) < 2:
        return
    said = "; ".join(f"{', '.join(ids)} (chain {key[0]}, pivots {shown[key]} mm)"
                     for key, ids in groups.items())
    first = ",".join(next(iter(groups.values())))
    raise ParameterError(f"the session's sphere tests describe {len(groups)} machine "
                         f"configurations: {said}; locate one at a time, e.g. "
                         f"{{measurements=}}{first}")


def locate(session: str | Path | Session, *,
           model: str | Path | MachineErrors | IdentificationResult | None = None,
           measurements: list[str] | None = None, prior_u: float | None = None) -> Located:
    """Identify the rotary axes' location errors from a session's probe_sphere and r_test tests.

    Parameters
    ----------
    session : str, Path or Session
        The session folder (or a read session).
    model : str, Path, IdentificationResult or MachineErrors, optional
        The linear axes' errors: a model file (``MODEL.json``: its estimate, and its
        covariance as a prior whose uncertainty the location errors' U then includes), an
        error table (``machine.csv``/``.toml``: taken as known) or the errors themselves;
        None: perfect linear axes.
    measurements : list of str, optional
        Ids of the probe_sphere and r_test measurements to use (default all).
    prior_u : float, optional
        Standard deviation of a zero-mean Gaussian prior on each determined location error
        [um for positions, urad for angles]; None: none (least squares).

    Returns
    -------
    Located

    Raises
    ------
    VolcalInputError
        No probe_sphere or r_test test, tests of different chains or pivots, an unmeasured
        test.
    """
    from volcal.identify.location import identify_location, separation_advice
    from volcal.kinds.probe_sphere import five_axis_machine, sphere_readings
    from volcal.kinds.r_test import rtest_readings_block
    from volcal.session.format import Session, read_session

    if prior_u is not None and not (math.isfinite(prior_u) and prior_u > 0):
        raise ParameterError(f"{{prior_u=}}{prior_u}: expected a positive standard deviation "
                             "[um or urad]")
    s = session if isinstance(session, Session) else read_session(session)
    ms = [m for m in s.measurements if m.kind in SPHERE_KINDS]
    if measurements is not None:
        unknown = sorted(set(measurements) - {m.id for m in ms})
        if unknown:
            other = next((m for m in s.measurements if m.id == unknown[0]), None)
            usable = ", ".join(m.id for m in ms) or "none"
            raise ParameterError(
                f"{{measurements=}}{unknown[0]!r}: "
                + (f"a {other.kind} test, not a probe_sphere or r_test test"
                   if other is not None else "no probe_sphere test of that id in the "
                   "session (nor an r_test test)")
                + f"; the session's tests that locate the rotary axes: {usable}")
        ms = [m for m in ms if m.id in measurements]
    if not ms:
        raise VolcalInputError("the session has no probe_sphere test and no r_test test "
                               "(docs/fiveaxis.md)",
                               s.path / "session.toml" if s.path else None)
    for m in ms:
        if m.deviation is None:
            what = ("no reported centres (x_mm, y_mm, z_mm)" if m.kind == "probe_sphere"
                    else "no readings (dx_um, dy_um, dz_um or s1_um, s2_um, s3_um)")
            raise VolcalInputError(f"{m.kind} test {m.id!r} is not measured: its CSV has {what}")
    _one_configuration(ms)
    loaded = _linear_model(model)
    linear = getattr(loaded, "errors", loaded)
    nominal = five_axis_machine(ms[0], linear)
    blocks = [sphere_readings(m) if m.kind == "probe_sphere" else rtest_readings_block(m)
              for m in ms]
    msgs_linear: list[str] = []
    prior = None
    if model is not None and nominal.linear is None:
        msgs_linear.append("The linear model's chain has another linear order than the tests' "
                           f"chain {nominal.chain_obj.code}: it is not used (perfect linear "
                           "axes).")
    elif model is not None:
        from volcal.identify.location_linear import linear_prior, linear_prior_note

        prior = linear_prior(loaded, nominal, blocks)
        msgs_linear.append(linear_prior_note(prior, loaded))
    else:
        msgs_linear.append("No linear model given: the linear axes are taken as perfect; their "
                           "errors along the poses' linear positions go into the location "
                           "errors unaccounted (volcal locate --model MODEL.json).")
        from volcal.kinds import kind_of

        if any(kind_of(m.kind).in_design for m in s.measurements):
            msgs_linear.append("The session holds tests of the linear axes: identify them "
                               "(volcal identify SESSION -o MODEL.json) and locate with "
                               "--model MODEL.json to take their errors, with their "
                               "uncertainty, into account.")
    res = identify_location(nominal, blocks, prior_u=prior_u, linear=prior)
    msgs = list(res.identifiability.messages) + separation_advice(nominal, blocks) + [
        f"Scatter of the readings: RMS {res.rms_before_um:.2f} um with the configured "
        f"kinematics, {res.rms_after_um:.2f} um with the identified location errors "
        f"(chi-square {res.chi2:.1f} on {res.dof} degrees of freedom)."] + msgs_linear
    msgs += _undetermined_share(res)
    if any(m.kind == "r_test" for m in ms):
        msgs.append("R-test readings carry the rotary axes' error motions over the angle "
                    "(radial, axial, tilt) too; they are not estimated and not separated from "
                    "the location errors: their mean and first harmonic over a turn are one "
                    "with the axis' location errors and the set-up (sphere, sensor zeros), "
                    "their values where another axis sweeps and the tilt motions (through the "
                    "sphere's lever arm) go partly into the location errors, the rest is left "
                    "in the scatter after identification (docs/fiveaxis.md).")
    return Located(res, nominal.chain_obj.code, tuple(m.id for m in ms), tuple(msgs),
                   tuple(blocks), tuple(m.kind for m in ms))


def located_json(located: Located) -> str:
    """The JSON text of ``volcal locate --json``.

    Parameters
    ----------
    located : Located
        The step's result.
    """
    return json.dumps(located.to_json(), indent=2, allow_nan=False) + "\n"
