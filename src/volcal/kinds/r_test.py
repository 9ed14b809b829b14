"""Kind ``r_test``: a sphere on the table read by three displacement sensors on the spindle.

The R-test (Weikert 2004; ISO 10791-6:2014, annex; Ibaraki et al. 2010): a precision
sphere fixed on the table and a nest of three displacement sensors in the spindle. Along a
path of the rotary axes the linear axes follow, so that the control's configured
kinematics keep the nominal sphere centre at the nest; where the rotary axes' lines sit
elsewhere than configured, the sphere moves in the nest. At each pose the reading is the
sphere's 3-D displacement relative to the nest (``dx_um, dy_um, dz_um`` along the machine
axes, or the three sensors' readings converted through their directions).
:func:`volcal.steps.locate.locate` identifies the location errors from them, alone or with
``probe_sphere`` tests of the same machine (``docs/fiveaxis.md``).

Session keys and CSV: :mod:`volcal.session.r_test` (``docs/formats.md``, "R-test
measurements"). ``Measurement.positions`` holds the commanded linear positions [mm];
the angles are the columns ``<axis>_deg``, the displacements the columns ``dx_um, dy_um,
dz_um``; ``Measurement.deviation`` is the length of the displacement [um] (computed on
reading, never stored).

What the readings do not separate: with unknown sensor zeros and an unknown sphere
position the positions of the table axes' lines are one with the sphere's set-up
(``docs/fiveaxis.md``, "What a design determines"), and the rotary axes' error motions over
the angle (radial, axial, tilt) are not estimated: their mean and first harmonic over a
full turn are one with the location errors of that axis and the set-up (sphere, sensor
zeros), their values where another axis sweeps and the tilt motions (through the sphere's
lever arm) go partly into the location errors, the rest stays in the residual
(``rms_after_um``; ``docs/fiveaxis.md``).

The kind is not part of the linear identification (:attr:`in_design` is False).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.kinds.outside_design import OutsideDesignKind
from volcal.kinds.probe_sphere import ProbeSphereKind, location_notes
from volcal.session.kinds import ReadContext, register_kind
from volcal.session.r_test import rtest_angles, rtest_keys
from volcal.session.r_test import rtest_machine as _machine

__all__ = ["RTestKind", "RTestSetup", "rtest_angles", "rtest_keys", "rtest_paths",
           "rtest_readings_block"]

C_STEP_DEG = 30.0
"""Default plan: C turns in steps of this angle over a full circle [deg]."""
TILT_FIXED_DEG = (0.0, -45.0, -90.0)
"""Default plan: the tilting axis' fixed angles of the C paths [deg]."""
TILT_SWEEP_DEG = (-90.0, 90.0, 15.0)
"""Default plan: the tilting axis' sweep at C = 0 (from, to, step) [deg]; from and to are
:data:`volcal.plan.fiveaxis.TILT_RANGE_DEG`, the tilting axis' default range."""
DEFAULT_NOISE_UM = 0.5
"""Default repeatability of one displacement component [um]."""


@dataclass
class RTestSetup:
    """The hidden truth of a simulated r_test.

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


def _displacement(m: Any) -> NDArray[np.float64]:
    return np.column_stack([np.asarray(m.columns[c], dtype=float)
                            for c in ("dx_um", "dy_um", "dz_um")])


def rtest_readings_block(m: Any):
    """The measurement as the location estimator's block (readings in the nest's frame).

    Parameters
    ----------
    m : Measurement
        A measured r_test measurement.

    Returns
    -------
    volcal.measure.spheres.SphereReadings
        ``kind = 'rtest'``: the displacement turned into the nest's frame
        (``R_head^T d``), the commanded positions, the sphere and the noise.
    """
    from volcal.measure.spheres import SphereReadings
    from volcal.session.r_test import head_rotation

    k = rtest_keys(m)
    ang = rtest_angles(m)
    R = head_rotation(k["chain"], ang)
    v = np.einsum("mji,mj->mi", R, _displacement(m))
    return SphereReadings(m.id, "rtest", ang, v, k["sphere"], k["sphere_mm"],
                          np.asarray(m.tool_offset, dtype=float),
                          np.asarray(m.positions, dtype=float), k["noise_um"])


def rtest_paths(pair: str, ranges: Any = None) -> dict[str, NDArray[np.float64]]:
    """The default R-test paths of a trunnion (ISO 10791-6; Ibaraki et al. 2010).

    C turns a full circle in steps of :data:`C_STEP_DEG` at each fixed angle
    :data:`TILT_FIXED_DEG` of the tilting axis (serpentine: up, down, up), then the tilting
    axis sweeps :data:`TILT_SWEEP_DEG` with C at its first angle. Within the machine's
    limited axes (``ranges``): C over its range; the fixed tilts three angles spanning the
    tilting axis' range from the angle nearest 0 where :data:`TILT_FIXED_DEG` do not all
    fit; the sweep over the whole range.

    Parameters
    ----------
    pair : str
        ``'ca'`` or ``'cb'``.
    ranges : volcal.plan.fiveaxis.TrunnionRanges, optional
        The angles the machine's axes allow (default: C a full turn, the tilt -90..+90).

    Returns
    -------
    dict of str to ndarray
        ``C`` and the tilting axis' letter: angle per pose [deg].
    """
    from volcal.plan.fiveaxis import TrunnionRanges

    r = ranges or TrunnionRanges()
    tilt = pair[1].upper()
    cs = r.c_angles(C_STEP_DEG)
    lo, hi = r.tilt
    fixed = [float(a) for a in TILT_FIXED_DEG]
    if not all(lo <= a <= hi for a in fixed):
        near = min(max(0.0, lo), hi)
        far = hi if hi - near >= near - lo else lo
        fixed = [near, 0.5 * (near + far), far]
    c_list: list[float] = []
    t_list: list[float] = []
    for i, a in enumerate(fixed):
        seq = cs if i % 2 == 0 else cs[::-1]
        c_list += [float(c) for c in seq]
        t_list += [a] * seq.size
    sweep = r.tilt_angles(TILT_SWEEP_DEG[2])
    c_list += [float(cs[0])] * sweep.size
    t_list += [float(v) for v in sweep]
    return {"C": np.array(c_list), tilt: np.array(t_list)}


class RTestKind(OutsideDesignKind):
    """R-test: the sphere's displacement in a nest of three sensors along rotary paths."""

    name: ClassVar[str] = "r_test"
    targets: ClassVar[tuple[str, ...]] = ("r_test_nest",)
    own_targets: ClassVar[tuple[str, ...]] = ("r_test_nest",)
    value_column: ClassVar[str] = "dx_um"
    value_unit: ClassVar[str] = "um"
    beam_in_session: ClassVar[bool] = False
    bidirectional: ClassVar[bool] = False
    standard: ClassVar[str | None] = None
    plan_tests: ClassVar[tuple[str, ...]] = ("r_test",)
    description: ClassVar[str] = ("R-test: a sphere's 3-D displacement in a nest of sensors "
                                  "along rotary paths, location errors of the rotary axes "
                                  "(docs/fiveaxis.md)")
    captured_by: ClassVar[str] = ""
    evaluated_by: ClassVar[str] = "the rotary axes' location errors, volcal locate"

    # -- session -----------------------------------------------------------------------
    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """The entry's keys and its CSV (``<axis>_deg``, ``x_mm...``, ``dx_um...``).

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        from volcal.errors import VolcalInputError
        from volcal.measure.spheres import probe_centres
        from volcal.session.format import MISSED_META, Measurement
        from volcal.session.r_test import check_rtest_keys, read_rtest_csv

        k = check_rtest_keys(entry, ctx.toml_path, ctx.where, ctx.id)
        meta = {key: v for key, v in entry.items()
                if key not in ("id", "kind", "target", "file", "tool_offset_mm", "beam_direction")}
        r = read_rtest_csv(ctx.csv_path, k["chain"], k["sensor_directions"], ctx.toml_path,
                           ctx.where)
        angles, q, d, missed, rows = r["angles"], r["q"], r["d"], r["missed"], r["rows"]
        n = rows.size
        if q is None:  # the configured kinematics' solution: the nest on the nominal sphere
            from volcal.model.fiveaxis import FiveAxisMachine
            from volcal.model.rotary import RotaryAxis

            rot = {a: RotaryAxis(a, k["pivot_mm"][a], full_circle=a == "C")
                   for a in k["chain"].rotary}
            q = probe_centres(FiveAxisMachine(k["chain"], rot), angles, k["sphere_mm"],
                              ctx.tool_offset)
        keep = ~missed
        if d is not None and missed.any():
            if ctx.require_deviation:
                meta[MISSED_META] = [{"row": int(rows[i]), "position_mm": [float(v) for v in q[i]],
                                      **{f"{a.lower()}_deg": float(angles[a][i]) for a in angles}}
                                     for i in np.flatnonzero(missed)]
                ctx.notes.append(f"{ctx.csv_path}: {int(missed.sum())} missed pose(s) left out")
            else:
                keep = np.ones(n, dtype=bool)
        if keep.sum() < 1:
            raise VolcalInputError("no pose read", ctx.csv_path, None, "dx_um")
        columns: dict[str, Any] = {f"{a.lower()}_deg": v[keep] for a, v in angles.items()}
        columns.update({c: v[keep] for c, v in r["extra"].items()})
        if d is not None:
            dd = np.nan_to_num(d[keep])
            for i, c in enumerate(("dx_um", "dy_um", "dz_um")):
                columns[c] = dd[:, i]
            if r["sensors"] is not None:
                s = np.nan_to_num(r["sensors"][keep])
                for i, c in enumerate(("s1_um", "s2_um", "s3_um")):
                    columns[c] = s[:, i]
        m = Measurement(ctx.id, self.name, ctx.target, np.asarray(q[keep], dtype=float), None,
                        np.array([0.0, 0.0, 1.0]), ctx.tool_offset, ctx.file, columns, meta,
                        rows[keep])
        if d is not None:
            m.deviation = np.linalg.norm(np.nan_to_num(d[keep]), axis=1)
        return m

    def csv_text(self, m: Any) -> str | None:
        """``<axis>_deg``, ``x_mm, y_mm, z_mm`` and ``dx_um, dy_um, dz_um`` (or s1..s3).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        from volcal.session.r_test import rtest_csv

        if m.deviation is None:
            return rtest_csv(rtest_angles(m), m.positions, None, m.columns)
        sensors = None
        if "s1_um" in m.columns:
            sensors = np.column_stack([np.asarray(m.columns[c], dtype=float)
                                       for c in ("s1_um", "s2_um", "s3_um")])
        return rtest_csv(rtest_angles(m), m.positions, _displacement(m), m.columns, sensors)

    # -- forward model -----------------------------------------------------------------
    def exact(self, machine: Any, m: Any, setup: Any = None) -> NDArray[np.float64]:
        """Exact readings of a virtual machine, counted from the first pose [um], (n, 3).

        The sphere's displacement relative to the nest along the machine axes, with the
        sensors zeroed at the first pose.

        Parameters
        ----------
        machine : MachineErrors
            The linear axes' errors of the virtual machine (used when the chain's linear
            order is the machine's).
        m : Measurement
            The measurement.
        setup : RTestSetup, optional
            The hidden location errors and sphere centre; None: none, the nominal sphere.
        """
        from volcal.measure.spheres import rtest_readings
        from volcal.session.r_test import head_rotation

        k = rtest_keys(m)
        loc = setup.location if setup is not None else {}
        sphere = setup.sphere_mm if setup is not None else k["sphere_mm"]
        fm = _machine(m, machine if hasattr(machine, "chain_obj") else None, loc)
        ang = rtest_angles(m)
        r = rtest_readings(fm, m.positions, ang, sphere, m.tool_offset)
        d = np.einsum("mij,mj->mi", head_rotation(k["chain"], ang), r)
        return np.asarray(d - d[0], dtype=float)

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Readings of a virtual 5-axis machine with hidden location errors.

        The location errors are those of the session's probe_sphere tests of the same
        chain (one draw per chain, :func:`volcal.measure.fiveaxis_virtual.random_location`:
        positions within +-2 mm, orientations and zeros within +-200 urad), the sphere
        drawn once per sphere id within +-1 mm of its nominal centre; the sensors zeroed at
        the first pose; noise of the test's ``noise_um`` on each displacement component.
        The machine's linear errors act as well (the linear axes follow the configured
        kinematics' positions, so their errors at those positions move the nest).

        Parameters
        ----------
        m : Measurement
            Planned measurement.
        machine : MachineErrors
            The virtual machine (linear axes).
        rng : numpy.random.Generator
            The simulation's generator.
        options : SimulationOptions
            Its dwell gives ``time_s``.
        shared : dict
            State shared by the measurements of one simulation.

        Returns
        -------
        RTestSetup
            The hidden truth (``truth/setup.toml``).
        """
        from volcal.measure.fiveaxis_virtual import random_location

        k = rtest_keys(m)
        chain = k["chain"].code
        locs = shared.setdefault("probe_sphere_location", {})
        if chain not in locs:
            locs[chain] = random_location(chain, rng)
        spheres = shared.setdefault("probe_sphere_spheres", {})
        if k["sphere"] not in spheres:
            spheres[k["sphere"]] = k["sphere_mm"] + rng.uniform(-1.0, 1.0, 3)
        setup = RTestSetup(chain, dict(locs[chain]), spheres[k["sphere"]])
        d = self.exact(machine, m, setup)
        # the CSV's resolution (0.1 nm), so that the file holds exactly the readings
        d = np.round(d + rng.normal(0.0, k["noise_um"], d.shape), 4)
        for i, c in enumerate(("dx_um", "dy_um", "dz_um")):
            m.columns[c] = d[:, i]
        for c in ("s1_um", "s2_um", "s3_um"):
            m.columns.pop(c, None)
        m.deviation = np.linalg.norm(d, axis=1)
        m.columns["time_s"] = np.arange(m.n) * options.dwell_s
        return setup

    # -- advise --------------------------------------------------------------------------
    def advise_notes(self, session: Any, planned: Any, options: Any) -> list[str]:
        """What the planned R-test paths will determine of the location errors.

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
        return location_notes(self.name, ms, lambda m: rtest_keys(m)["chain"].code, _machine,
                              lambda m: rtest_readings_block(_zero_readings(m)))

    # the probe_sphere kind's hook itself: a session with both kinds gets one section
    report_section = ProbeSphereKind.report_section

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
        from volcal.program.r_test import rtest_program_positions

        return rtest_program_positions(m)

    def program_text(self, m: Any, dialect: str, name: str, number: int, options: Any
                     ) -> tuple[str, list[str]] | None:
        """The R-test path for LinuxCNC (:mod:`volcal.program.r_test`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect (other than LinuxCNC: a listing of the poses).
        name : str
            Program name.
        number : int
            Program number.
        options : volcal.program.steps.ProgramOptions
            Decimals, safe Z, feed, dwell.
        """
        from volcal.program.r_test import rtest_program

        return rtest_program(m, dialect, name, number, options)

    # -- plan ----------------------------------------------------------------------------
    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """A trunnion's R-test: C turning at fixed tilts, then the tilt sweeping at C = 0.

        The chain is ``CA`` + the plan's linear chain (``only`` = ``cb`` for a B cradle);
        the pivots and sphere of :func:`volcal.plan.fiveaxis.default_trunnion` (the
        probe_sphere plan's: the two locate together; every position of the paths inside
        the travel); the paths of :func:`rtest_paths` within the machine's limited rotary
        axes (``options.rotary["axes"]``, ``--rotary-axes`` or the session's
        ``[[machine.rotary_axes]]``: :func:`volcal.plan.fiveaxis.trunnion_ranges`); the
        commanded positions are the configured kinematics' (the nest on the nominal
        sphere). Edit the session's pivots, sphere, nest offset and paths to the machine's.

        Parameters
        ----------
        test : str
            ``'r_test'``.
        options : volcal.plan.planner.PlanOptions
            The plan's travel and chain.
        only : str or None
            Rotary letters of the table (``'ca'`` default, ``'cb'``).
        """
        from volcal.errors import VolcalInputError
        from volcal.measure.spheres import probe_centres
        from volcal.model.chain import parse_machine_chain
        from volcal.model.fiveaxis import FiveAxisMachine
        from volcal.model.rotary import RotaryAxis
        from volcal.plan.fiveaxis import default_trunnion, trunnion_ranges
        from volcal.session.format import Measurement

        pair = (only or "ca").lower()
        if len(pair) != 2 or pair[0] != "c" or pair[1] not in "ab":
            raise VolcalInputError(f"r_test:{only}: expected ca or cb (C on an A or B cradle)")
        chain = parse_machine_chain(pair.upper() + options.chain)
        ranges = trunnion_ranges(pair, options.rotary.get("axes"))
        lay = default_trunnion(pair, options.chain, options.t, ranges)
        pivots = lay.pivot_mm
        sphere = np.array(lay.sphere_mm)
        pc, pt = np.array(pivots["c"]), np.array(pivots[pair[1]])
        ang = rtest_paths(pair, ranges)
        rot = {"C": RotaryAxis("C", pc), pair[1].upper(): RotaryAxis(pair[1].upper(), pt,
                                                                      full_circle=False)}
        q = probe_centres(FiveAxisMachine(chain, rot), ang, sphere, np.zeros(3))
        meta = {"chain": chain.code, "pivot_mm": pivots, "sphere": "R1",
                "sphere_mm": [float(v) for v in sphere], "noise_um": DEFAULT_NOISE_UM}
        cols = {f"{r.lower()}_deg": a for r, a in ang.items()}
        mid = "r_test" if pair == "ca" else f"r_test_{pair}"
        return [Measurement(mid, self.name, "r_test_nest", np.round(q, 6), None,
                            np.array([0.0, 0.0, 1.0]), np.zeros(3), f"{mid}.csv", cols, meta)]


def _zero_readings(m: Any) -> Any:
    """A copy of a (planned) measurement with zero displacements, for the design's analysis."""
    import copy

    c = copy.copy(m)
    c.columns = dict(m.columns)
    for col in ("dx_um", "dy_um", "dz_um"):
        c.columns.setdefault(col, np.zeros(m.n))
    return c


R_TEST = register_kind(RTestKind)
