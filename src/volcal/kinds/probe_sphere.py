"""Kind ``probe_sphere``: the centre of a calibration sphere probed at rotary poses.

A touch probe in the spindle measures a sphere fixed on the workpiece side at a set of
poses of the rotary axes; the control reports the sphere centre in its machine
coordinates at each pose (HEIDENHAIN KinematicsOpt cycle 451, Siemens CYCLE996, ISG's
measuring cycle, or volcal's fit of the points LinuxCNC logs while probing with
``G38.2``). Where the rotary axes' lines sit elsewhere than the control assumes, the
reported centres scatter; :func:`volcal.steps.locate.locate` identifies the location
errors (``EX0C`` ...) from them (``docs/fiveaxis.md``).

Session keys and CSV: :mod:`volcal.session.probe_sphere` (``docs/formats.md``,
"Probe-on-sphere tests"). ``Measurement.positions`` holds the reported centres [mm]; the
angles are the columns ``<axis>_deg``; ``Measurement.deviation`` is the dispersion the
control's own cycles report: the distance of the sphere centre each pose gives through the
nominal kinematics from their mean [um] (computed on reading, never stored).

The kind is not part of the linear identification (:attr:`in_design` is False).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.kinds.outside_design import OutsideDesignKind
from volcal.session.kinds import ReadContext, register_kind
from volcal.session.probe_sphere import (
    _angles,
    _keys,
    dispersion_um,
    five_axis_machine,
)

__all__ = ["ProbeSetup", "ProbeSphereKind", "dispersion_um", "five_axis_machine",
           "location_notes", "sphere_readings"]

KEYS = ("chain", "pivot_mm", "sphere", "sphere_mm", "sphere_diameter_mm", "noise_um")
"""The kind's own keys of a ``[[measurements]]`` entry."""


@dataclass
class ProbeSetup:
    """The hidden truth of a simulated probe_sphere test.

    Attributes
    ----------
    chain : str
        The chain.
    location : dict of str to float
        True location errors [um, urad].
    sphere_mm : ndarray, shape (3,)
        True sphere centre [mm].
    """

    chain: str
    location: dict[str, float]
    sphere_mm: NDArray[np.float64]

    def to_truth(self) -> dict[str, Any]:
        """The set-up's entry of ``truth/setup.toml``."""
        return {"chain": self.chain, "location": {k: float(v) for k, v in self.location.items()},
                "sphere_mm": [float(v) for v in self.sphere_mm]}


def sphere_readings(m: Any, nominal_centres: bool = False):
    """The measurement as the location estimator's block.

    Parameters
    ----------
    m : Measurement
        A measured probe_sphere measurement.
    nominal_centres : bool
        Use the centres the configured kinematics predict instead of the readings (a
        planned test, for the design's analysis).

    Returns
    -------
    volcal.measure.spheres.SphereReadings
    """
    from volcal.measure.spheres import SphereReadings

    k = _keys(m)
    values = np.asarray(m.positions, dtype=float)
    if nominal_centres:
        from volcal.measure.spheres import probe_centres

        values = probe_centres(five_axis_machine(m), _angles(m), k["sphere_mm"], m.tool_offset)
    return SphereReadings(m.id, "probe", _angles(m), values,
                          k["sphere"], k["sphere_mm"], np.asarray(m.tool_offset, dtype=float),
                          None, k["noise_um"])


def location_notes(kind: str, ms: list[Any], chain_of: Callable[[Any], str],
                   machine_of: Callable[[Any], Any], block_of: Callable[[Any], Any]
                   ) -> list[str]:
    """What a kind's planned tests determine of the location errors, per chain.

    The identifiability report (:func:`volcal.identify.location.analyse_location`) and the
    separation advice of each chain's tests, shared by the probe_sphere and r_test kinds.

    Parameters
    ----------
    kind : str
        The kind's name, leading each note.
    ms : list of Measurement
        The kind's tests.
    chain_of : callable
        A test's chain code.
    machine_of : callable
        A test's nominal five-axis machine.
    block_of : callable
        A test's readings block at its planned poses (zero readings).

    Returns
    -------
    list of str
    """
    from volcal.identify.location import (
        analyse_location,
        design_jacobian,
        separation_advice,
    )
    from volcal.model.fiveaxis import location_parameter_names

    notes: list[str] = []
    for chain in dict.fromkeys(chain_of(m) for m in ms):
        group = [m for m in ms if chain_of(m) == chain]
        nominal = machine_of(group[0])
        blocks = [block_of(m) for m in group]
        Jx, Jn, nn, _, _ = design_jacobian(nominal, blocks)
        rep = analyse_location(Jx, Jn, location_parameter_names(chain), nn, nominal.chain_obj)
        notes += [f"{kind} ({chain}): {msg}" for msg in rep.messages]
        notes += [f"{kind} ({chain}): {msg}" for msg in separation_advice(nominal, blocks)]
    return notes


class ProbeSphereKind(OutsideDesignKind):
    """Sphere centres probed at rotary poses (5-axis location errors)."""

    name: ClassVar[str] = "probe_sphere"
    targets: ClassVar[tuple[str, ...]] = ("touch_probe",)
    own_targets: ClassVar[tuple[str, ...]] = ("touch_probe",)
    value_column: ClassVar[str] = "x_mm"
    value_unit: ClassVar[str] = "um"
    beam_in_session: ClassVar[bool] = False
    bidirectional: ClassVar[bool] = False
    standard: ClassVar[str | None] = None
    linear_nodes: ClassVar[bool] = False
    plan_tests: ClassVar[tuple[str, ...]] = ("probe_sphere",)
    description: ClassVar[str] = ("sphere centres probed at rotary poses: location errors of "
                                  "the rotary axes (docs/fiveaxis.md)")
    captured_by: ClassVar[str] = ("its readings are its probe program's log (volcal import "
                                  "LOG --session S --measurement ID; docs/fiveaxis.md)")
    evaluated_by: ClassVar[str] = "the rotary axes' location errors, volcal locate"

    # -- session -----------------------------------------------------------------------
    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """The entry's keys and its CSV (``<axis>_deg``, ``x_mm, y_mm, z_mm``).

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        from volcal.errors import VolcalInputError
        from volcal.session.format import MISSED_META, Measurement
        from volcal.session.probe_sphere import check_probe_keys, read_probe_csv

        k = check_probe_keys(entry, ctx.toml_path, ctx.where, ctx.id)
        meta = {key: v for key, v in entry.items()
                if key not in ("id", "kind", "target", "file", "tool_offset_mm", "beam_direction")}
        angles, centres, rows, missed, extra = read_probe_csv(ctx.csv_path, k["chain"])
        n = rows.size
        keep = ~missed
        if centres is not None and missed.any():
            if ctx.require_deviation:
                meta[MISSED_META] = [{"row": int(rows[i]), "position_mm": [0.0, 0.0, 0.0],
                                      **{f"{r.lower()}_deg": float(angles[r][i])
                                         for r in angles}}
                                     for i in np.flatnonzero(missed)]
                ctx.notes.append(f"{ctx.csv_path}: {int(missed.sum())} missed pose(s) left out")
            else:
                keep = np.ones(n, dtype=bool)
        if keep.sum() < 1:
            raise VolcalInputError("no probed pose left", ctx.csv_path, None, "x_mm")
        columns: dict[str, Any] = {f"{r.lower()}_deg": a[keep] for r, a in angles.items()}
        columns.update({c: v[keep] for c, v in extra.items()})
        pos = np.zeros((int(keep.sum()), 3)) if centres is None else np.nan_to_num(centres[keep])
        m = Measurement(ctx.id, self.name, ctx.target, pos, None, np.array([0.0, 0.0, 1.0]),
                        ctx.tool_offset, ctx.file, columns, meta, rows[keep])
        if centres is not None:
            m.deviation = dispersion_um(m, pos)
        return m

    def csv_text(self, m: Any) -> str | None:
        """``<axis>_deg`` per rotary axis, ``x_mm, y_mm, z_mm`` [deg, mm].

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.session.probe_sphere import probe_csv

        return probe_csv(_angles(m), None if m.deviation is None else m.positions, m.columns)

    # -- forward model -----------------------------------------------------------------
    def exact(self, machine: Any, m: Any, setup: Any = None) -> NDArray[np.float64]:
        """Exact reported centres of a virtual machine [mm], shape (n, 3).

        Parameters
        ----------
        machine : MachineErrors
            The linear axes' errors of the virtual machine (used when the chain's linear
            order is the machine's).
        m : Measurement
            The measurement.
        setup : ProbeSetup, optional
            The hidden location errors and sphere centre; None: none, the nominal sphere.
        """
        from volcal.measure.spheres import probe_centres

        k = _keys(m)
        loc = setup.location if setup is not None else {}
        sphere = setup.sphere_mm if setup is not None else k["sphere_mm"]
        fm = five_axis_machine(m, machine if hasattr(machine, "chain_obj") else None, loc)
        return probe_centres(fm, _angles(m), sphere, m.tool_offset)

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Reported centres of a virtual 5-axis machine with hidden location errors.

        The location errors are drawn once per chain (shared by the session's tests:
        positions of the axis lines within +-2 mm, orientations and zeros within +-200 urad,
        :func:`volcal.measure.fiveaxis_virtual.random_location`), the sphere once per
        sphere id (within +-1 mm of its nominal centre); probe noise of the test's
        ``noise_um`` on every coordinate. The machine's linear errors act as well.

        Parameters
        ----------
        m : Measurement
            Planned measurement.
        machine : MachineErrors
            The virtual machine (linear axes).
        rng : numpy.random.Generator
            The simulation's generator.
        options : SimulationOptions
            Unused but for the dwell (``time_s``).
        shared : dict
            State shared by the measurements of one simulation.

        Returns
        -------
        ProbeSetup
            The hidden truth (``truth/setup.toml``).
        """
        from volcal.measure.fiveaxis_virtual import random_location

        k = _keys(m)
        chain = k["chain"].code
        locs = shared.setdefault("probe_sphere_location", {})
        if chain not in locs:
            locs[chain] = random_location(chain, rng)
        spheres = shared.setdefault("probe_sphere_spheres", {})
        if k["sphere"] not in spheres:
            spheres[k["sphere"]] = k["sphere_mm"] + rng.uniform(-1.0, 1.0, 3)
        setup = ProbeSetup(chain, dict(locs[chain]), spheres[k["sphere"]])
        c = self.exact(machine, m, setup)
        # the CSV's resolution (1 nm), so that the file holds exactly the readings
        c = np.round(c + rng.normal(0.0, k["noise_um"], c.shape) * 1e-3, 6)
        m.positions = c
        m.deviation = dispersion_um(m, c)
        m.columns["time_s"] = np.arange(m.n) * options.dwell_s
        return setup

    # -- advise --------------------------------------------------------------------------
    def advise_notes(self, session: Any, planned: Any, options: Any) -> list[str]:
        """What the planned probe_sphere poses will determine of the location errors.

        Parameters
        ----------
        session : Session
            The planned session.
        planned : Session
            Its copy with zero readings.
        options : IdentifyOptions
            Unused.
        """
        ms = [m for m in session.measurements + session.unmeasured if m.kind == self.name]
        return location_notes(self.name, ms, lambda m: _keys(m)["chain"].code,
                              five_axis_machine,
                              lambda m: sphere_readings(m, nominal_centres=True))

    def report_section(self, inp: Any) -> Any:
        """The location errors with U (:mod:`volcal.report.fiveaxis`).

        Parameters
        ----------
        inp : volcal.report.sections.ReportInputs
            The session and its results.
        """
        from volcal.report.fiveaxis import location_section

        return location_section(inp)

    # -- program -------------------------------------------------------------------------
    def program_positions(self, m: Any, dialect: str) -> list[tuple[str, Any]]:
        """The machine positions the program commands (checked against the travel).

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect.
        """
        from volcal.program.probe_sphere import probe_program_positions

        return probe_program_positions(m, dialect)

    def program_text(self, m: Any, dialect: str, name: str, number: int, options: Any
                     ) -> tuple[str, list[str]] | None:
        """LinuxCNC ``G38.2`` probing with a probe log (:mod:`volcal.program.probe_sphere`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect (other than LinuxCNC: a listing of the poses for the control's cycle).
        name : str
            Program name.
        number : int
            Program number.
        options : volcal.program.steps.ProgramOptions
            Decimals, safe Z.
        """
        from volcal.program.probe_sphere import probe_program

        return probe_program(m, dialect, name, number, options)

    def program_files(self, m: Any, dialect: str, name: str) -> dict[str, str]:
        """HEIDENHAIN: the ``FN 16`` format file the program prints with.

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect.
        name : str
            Program name.
        """
        from volcal.program.probe_sphere import probe_program_files

        return probe_program_files(m, dialect, name)

    # -- plan ----------------------------------------------------------------------------
    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """A trunnion's probe test: C at 6 angles x A at 5 angles, one sphere.

        The chain is ``CA`` + the plan's linear chain (``only`` = another pair of rotary
        letters, e.g. ``cb``, read workpiece side first); the pivots and sphere of
        :func:`volcal.plan.fiveaxis.default_trunnion` (the r_test plan's: planned together
        the two locate together; every pose's sphere centre inside the travel;
        ``docs/fiveaxis.md``); the angles within the machine's limited rotary axes
        (:func:`volcal.plan.fiveaxis.trunnion_ranges`). Edit the session's pivots, sphere
        and poses to the machine's.

        Parameters
        ----------
        test : str
            ``'probe_sphere'``.
        options : volcal.plan.planner.PlanOptions
            The plan's travel and chain.
        only : str or None
            Rotary letters of the table (``'ca'`` default, ``'cb'``).
        """
        from volcal.errors import VolcalInputError
        from volcal.measure.fiveaxis_virtual import pose_grid
        from volcal.model.chain import parse_machine_chain
        from volcal.plan.fiveaxis import default_trunnion, trunnion_ranges
        from volcal.session.format import Measurement

        pair = (only or "ca").lower()
        if len(pair) != 2 or pair[0] != "c" or pair[1] not in "ab":
            raise VolcalInputError(f"probe_sphere:{only}: expected ca or cb (C on an A or B "
                                   "cradle)")
        chain = parse_machine_chain(pair.upper() + options.chain)
        ranges = trunnion_ranges(pair, options.rotary.get("axes"))
        lay = default_trunnion(pair, options.chain, options.t, ranges)
        pivots, sphere = lay.pivot_mm, lay.sphere_mm
        c_lo, c_hi = ranges.c
        ang = pose_grid(chain.code, {"C": (c_lo, c_lo + 360.0) if ranges.c_full else (c_lo, c_hi),
                                     pair[1].upper(): ranges.tilt})
        n = ang["C"].size
        meta = {"chain": chain.code, "pivot_mm": pivots, "sphere": "S1", "sphere_mm": sphere,
                "noise_um": 1.0}
        cols = {f"{r.lower()}_deg": a for r, a in ang.items()}
        mid = "probe_sphere" if pair == "ca" else f"probe_sphere_{pair}"
        return [Measurement(mid, self.name, "touch_probe", np.zeros((n, 3)), None,
                            np.array([0.0, 0.0, 1.0]), np.zeros(3), f"{mid}.csv", cols,
                            meta)]


PROBE_SPHERE = register_kind(ProbeSphereKind)
