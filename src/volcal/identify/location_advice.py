r"""Which extra pose or sphere position adds most to the location errors: a ranking.

Before measuring (``volcal advise``), each candidate -- one more pose of the rotary axes
on a sphere of the design, or a second sphere measured at the design's poses -- is added
to the design in turn, and the candidates are ranked by what they add to the
identification of the location errors (:mod:`volcal.identify.location`):

1. **what they determine**: the errors the design holds at zero (redundant) that the
   design with the candidate separates (the identifiability analysis of
   :func:`volcal.identify.location.analyse_location`, the same as ``volcal locate``'s);
2. **the information per pose** (D-optimal design): the gain in
   ``log det(J_x^T (I - P_n) J_x + \Lambda_0)``, the information on every location error
   with the nuisances (sphere centres, sensor zeros) eliminated and a weak prior
   ``\Lambda_0`` (1 mm or 1 mrad, :data:`PRIOR_SCALE`) that keeps the redundant errors
   finite, divided by the number of poses the candidate adds. ``exp(gain / 2)`` is the
   factor by which the volume of the uncertainty ellipsoid shrinks.

For each candidate the ranking gives the expanded uncertainty (k = 2) of every error the
design with the candidate determines, computed as ``volcal locate`` computes it (the
linearised covariance of the least-squares estimate, no prior, the stated probe noise),
at the nominal machine: the location errors the readings will show move it by a small
fraction (first order in the errors over the lever arms).

References: Atkinson, Donev, Tobias, *Optimum Experimental Designs, with SAS*, 2007,
ch. 10-11 (D-optimum designs, sequential construction); Ibaraki et al. 2012 and the
ISG / HEIDENHAIN measuring-cycle documentation (sphere far from the axis, large angle
differences).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.identify.location import analyse_location, design_jacobian
from volcal.measure.spheres import SphereReadings, probe_centres
from volcal.model.fiveaxis import FiveAxisMachine, location_parameter_names
from volcal.model.names import info

__all__ = ["PRIOR_SCALE", "Candidate", "PoseRanking", "RankedCandidate",
           "default_candidates", "rank_candidates", "read_candidates"]

Array = NDArray[np.float64]
PRIOR_SCALE = 1000.0
"""Standard deviation of the weak prior of the D-criterion [um for positions, urad for
orientations and zeros]: location errors of a machine before compensation are up to a
few hundred um (issue 28)."""
COVERAGE_K = 2.0
"""Coverage factor of the predicted U."""
RANGE_DEFAULT = {"A": (-90.0, 90.0), "B": (-90.0, 90.0), "C": (0.0, 360.0)}
"""Angle ranges of the generated candidates without ``[[machine.rotary_axes]]`` [deg]."""
STEP_DEG = {"full": 30.0, "limited": 15.0}
"""Angle step of the generated candidates: a full-circle axis, a limited one [deg]."""
SPHERE_RADII_MM = (75.0, 150.0, 250.0)
"""Distances of a generated second sphere from the first rotary axis [mm]."""
SPHERE_HEIGHTS_MM = (0.0, 40.0, 150.0)
"""Heights of a generated second sphere above the first axis' pivot [mm]."""


@dataclass(frozen=True)
class Candidate:
    """Extra readings to add to a design.

    Attributes
    ----------
    label : str
        What to measure, in words (``'C 90°, A 45° on S1'``).
    kind : str
        ``'pose'`` (poses on a sphere of the design) or ``'sphere'`` (another sphere).
    blocks : tuple of SphereReadings
        The readings (poses, sphere, tool, noise; the values are not used).
    where : str
        The geometry in words (``'sphere 150 mm off the C axis'``).
    """

    label: str
    kind: str
    blocks: tuple[SphereReadings, ...]
    where: str = ""

    @property
    def n_poses(self) -> int:
        """Poses the candidate adds."""
        return sum(b.n_poses for b in self.blocks)


@dataclass(frozen=True)
class RankedCandidate:
    """One candidate with what it adds.

    Attributes
    ----------
    rank : int
        1 = best.
    label, kind, where : str
        As :class:`Candidate`.
    n_poses : int
        Poses it adds.
    angles : dict of str to list of float
        Its poses [deg].
    sphere_mm : list of float
        Its sphere's nominal centre [mm].
    determines : tuple of str
        Errors the design holds at zero that the design with it determines.
    gain : float
        Gain in log det of the information (weak prior) [nepers, 2 ln of the volume].
    gain_per_pose : float
        ``gain / n_poses``.
    U_after : dict of str to float
        Predicted U (k = 2) of every error the design with it determines [um, urad].
    reason : str
        Why, in plain words.
    """

    rank: int
    label: str
    kind: str
    where: str
    n_poses: int
    angles: dict[str, list[float]]
    sphere_mm: list[float]
    determines: tuple[str, ...]
    gain: float
    gain_per_pose: float
    U_after: dict[str, float]
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {"rank": self.rank, "label": self.label, "kind": self.kind, "where": self.where,
                "n_poses": self.n_poses, "angles_deg": self.angles,
                "sphere_mm": self.sphere_mm, "determines": list(self.determines),
                "gain": self.gain, "gain_per_pose": self.gain_per_pose,
                "U_after": self.U_after, "reason": self.reason}


@dataclass(frozen=True)
class PoseRanking:
    """The candidates of one chain's design, best first.

    Attributes
    ----------
    chain : str
        Chain code.
    measurements : tuple of str
        The design's probe_sphere tests.
    determined, redundant : tuple of str
        What the design determines and holds at zero.
    U : dict of str to float
        Predicted U (k = 2) of the determined errors of the design as it is [um, urad].
    candidates : tuple of RankedCandidate
        The best ones (``top``), best first.
    n_candidates : int
        Candidates tried.
    source : str
        ``'generated'`` or the candidates file.
    """

    chain: str
    measurements: tuple[str, ...]
    determined: tuple[str, ...]
    redundant: tuple[str, ...]
    U: dict[str, float]
    candidates: tuple[RankedCandidate, ...] = field(default_factory=tuple)
    n_candidates: int = 0
    source: str = "generated"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (``volcal advise --json``: ``location_candidates``)."""
        return {"chain": self.chain, "measurements": list(self.measurements),
                "determined": list(self.determined), "redundant": list(self.redundant),
                "U": self.U, "coverage_factor": COVERAGE_K,
                "n_candidates": self.n_candidates, "source": self.source,
                "candidates": [c.to_dict() for c in self.candidates]}

    def lines(self) -> list[str]:
        """The ranking in plain words, as ``volcal advise`` prints it."""
        head = (f"probe_sphere ({self.chain}): {self.n_candidates} candidate poses and sphere "
                f"positions ({self.source}) ranked by what they add to the location errors "
                "(errors they determine, then information per pose); best first:")
        now = ", ".join(f"{n} {v:.3g}" for n, v in self.U.items())
        out = [head, f"  the design as planned: predicted U, k = 2: {now}"]
        for c in self.candidates:
            us = ", ".join(f"{n} {v:.3g}" for n, v in c.U_after.items())
            out.append(f"  {c.rank}. {c.label}: {c.reason} (predicted U, k = 2: {us})")
        return out


# -- Jacobians ---------------------------------------------------------------------------
def _rows(base: FiveAxisMachine, blocks: Sequence[SphereReadings]
          ) -> tuple[Array, Array, list[str]]:
    Jx, Jn, nn, _, _ = design_jacobian(base, blocks)
    return Jx, Jn, nn


def _stack(parts: Sequence[tuple[Array, Array, list[str]]]) -> tuple[Array, Array, list[str]]:
    """Rows of several parts on the union of their nuisance columns."""
    names = list(dict.fromkeys(n for _, _, nn in parts for n in nn))
    Jn = np.zeros((sum(p[0].shape[0] for p in parts), len(names)))
    r = 0
    for Jx_, Jn_, nn in parts:
        for j, n in enumerate(nn):
            Jn[r:r + Jx_.shape[0], names.index(n)] = Jn_[:, j]
        r += Jx_.shape[0]
    return np.vstack([p[0] for p in parts]), Jn, names


def _eliminated(Jx: Array, Jn: Array) -> Array:
    """``(I - P_n) J_x``: the rows with the nuisances' directions removed."""
    if Jn.shape[1] == 0:
        return Jx
    U, s, _ = np.linalg.svd(Jn, full_matrices=False)
    Q = U[:, s > s.max() * 1e-10] if s.size and s.max() > 0 else U[:, :0]
    return Jx - Q @ (Q.T @ Jx)


def _prior(names: Sequence[str]) -> Array:
    return np.full(len(names), 1.0 / PRIOR_SCALE ** 2)


def _logdet(X: Array, names: Sequence[str]) -> float:
    sign, ld = np.linalg.slogdet(X.T @ X + np.diag(_prior(names)))
    return float(ld)


def _U(X: Array, names: Sequence[str], free: Sequence[str]) -> dict[str, float]:
    """Predicted U (k = 2) of the free errors, least squares without prior."""
    if not free:
        return {}
    Xf = X[:, [list(names).index(n) for n in free]]
    cov = np.linalg.inv(Xf.T @ Xf)
    return {n: COVERAGE_K * math.sqrt(max(float(cov[i, i]), 0.0)) for i, n in enumerate(free)}


def _worst_pair(X: Array, names: Sequence[str], free: Sequence[str]) -> tuple[str, str, float]:
    """The two errors the worst-separated combination mixes most, its relative s.v."""
    Xf = X[:, [list(names).index(n) for n in free]]
    Xf = Xf / np.maximum(np.linalg.norm(Xf, axis=0), 1e-300)
    _, s, Vt = np.linalg.svd(Xf, full_matrices=False)
    v = np.abs(Vt[-1])
    i, j = np.argsort(v)[::-1][:2]
    return free[i], free[j], float(s[-1] / s[0]) if s[0] > 0 else 0.0


# -- candidates --------------------------------------------------------------------------
def _axis_words(nominal: FiveAxisMachine, sphere_mm: Array) -> str:
    r0 = nominal.chain_obj.rotary[0]
    ax = nominal.rotary[r0]
    e = np.eye(3)["ABC".index(r0)]
    d = np.asarray(sphere_mm, dtype=float) - np.asarray(ax.pivot_mm, dtype=float)
    radial = float(np.linalg.norm(d - (d @ e) * e))
    return f"{radial:.0f} mm off the {r0} axis"


def _grid(letters: Sequence[str], ranges: Mapping[str, tuple[float, float]]
          ) -> dict[str, Array]:
    import itertools

    axes = []
    for r in letters:
        lo, hi = ranges.get(r, RANGE_DEFAULT[r])
        full = hi - lo >= 360.0 - 1e-9
        step = STEP_DEG["full" if full else "limited"]
        n = int(math.floor((hi - lo) / step + 1e-9))
        vals = lo + step * np.arange(n if full else n + 1)
        axes.append(vals)
    poses = list(itertools.product(*axes))
    return {r: np.array([p[i] for p in poses], dtype=float) for i, r in enumerate(letters)}


def _one(b: SphereReadings, base: FiveAxisMachine, angles: dict[str, Array], sphere: str,
         sphere_mm: Array) -> SphereReadings:
    m = next(iter(angles.values())).size
    q = probe_centres(base, angles, sphere_mm, b.tool_offset_mm) if b.kind == "rtest" else None
    return SphereReadings(b.id, b.kind, angles, np.zeros((m, 3)), sphere, np.asarray(
        sphere_mm, dtype=float), b.tool_offset_mm, q, b.noise_um)


def _pose_label(angles: Mapping[str, float], sphere: str) -> str:
    return ", ".join(f"{r} {a:g}°" for r, a in angles.items()) + f" on {sphere}"


def default_candidates(nominal: FiveAxisMachine, blocks: Sequence[SphereReadings],
                       ranges: Mapping[str, tuple[float, float]] | None = None
                       ) -> list[Candidate]:
    """The generated candidates: single poses on each sphere, second spheres.

    Parameters
    ----------
    nominal : FiveAxisMachine
        The configured machine.
    blocks : sequence of SphereReadings
        The design.
    ranges : mapping of str to (float, float), optional
        Range of each rotary axis [deg] (``[[machine.rotary_axes]]``); default
        :data:`RANGE_DEFAULT`.

    Returns
    -------
    list of Candidate
        Every pose of a grid over the ranges (every 30 deg of a full-circle axis, every
        15 deg of a limited one) not in the design, on each sphere of the design; a
        second sphere at each of :data:`SPHERE_RADII_MM` from the first rotary axis x
        :data:`SPHERE_HEIGHTS_MM` above its pivot, measured at the first test's poses.
    """
    base = nominal.with_location(np.zeros(len(location_parameter_names(nominal.chain_obj))))
    letters = list(nominal.chain_obj.rotary)
    grid = _grid(letters, ranges or {})
    out: list[Candidate] = []
    for sphere in dict.fromkeys(b.sphere for b in blocks):
        b = next(x for x in blocks if x.sphere == sphere)
        have = {tuple(round(float(x.angles[r][i]), 6) for r in letters)
                for x in blocks if x.sphere == sphere for i in range(x.n_poses)}
        words = f"sphere {sphere} {_axis_words(nominal, b.sphere_mm)}"
        for i in range(next(iter(grid.values())).size):
            key = tuple(round(float(grid[r][i]), 6) for r in letters)
            if key in have:
                continue
            ang = {r: np.array([grid[r][i]]) for r in letters}
            out.append(Candidate(_pose_label({r: grid[r][i] for r in letters}, sphere), "pose",
                                 (_one(b, base, ang, sphere, b.sphere_mm),), words))
    b0 = blocks[0]
    r0 = letters[0]
    e = np.eye(3)["ABC".index(r0)]
    c = np.asarray(nominal.rotary[r0].pivot_mm, dtype=float)
    d = np.asarray(b0.sphere_mm, dtype=float) - c
    d = d - (d @ e) * e
    d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else np.roll(e, 1)
    for r_mm in SPHERE_RADII_MM:
        for h_mm in SPHERE_HEIGHTS_MM:
            pos = c + r_mm * d + h_mm * e
            words = f"a second sphere {r_mm:g} mm off the {r0} axis, {h_mm:g} mm above its pivot"
            out.append(Candidate(f"{words}, at the {b0.n_poses} poses of {b0.id}", "sphere",
                                 (_one(b0, base, dict(b0.angles), "candidate_sphere", pos),),
                                 words))
    return out


def read_candidates(path: str | Path, nominal: FiveAxisMachine,
                    blocks: Sequence[SphereReadings]) -> list[Candidate]:
    """Candidates from a CSV file (``docs/fiveaxis.md``, "Ranking poses").

    One ``<axis>_deg`` column per rotary axis of the chain (``c_deg, a_deg``); optional
    ``sphere_x_mm, sphere_y_mm, sphere_z_mm`` (another sphere's nominal centre; empty or
    absent: the first test's sphere) and ``candidate`` (a name: the rows of one name form
    one candidate, e.g. a second sphere at several poses; absent: each row is one).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    nominal : FiveAxisMachine
        The configured machine.
    blocks : sequence of SphereReadings
        The design (its first test gives the tool offset, noise and sphere).

    Returns
    -------
    list of Candidate

    Raises
    ------
    VolcalInputError
        Naming the file, row and column.
    """
    from volcal.io.table import Column, TableSpec, read_table

    letters = [r.lower() for r in nominal.chain_obj.rotary]
    spec = TableSpec(
        columns=tuple(Column(f"{r}_deg", abs_max=3600.0) for r in letters)
        + tuple(Column(f"sphere_{a}_mm", required=False, empty=True, abs_max=1e5)
                for a in "xyz")
        + (Column("candidate", kind="str", required=False, empty=True),),
        min_rows=1, what="candidate poses file", delimiters=",;\t", decimal_comma=True)
    t = read_table(path, spec)
    n = len(t)
    have = [t.has(f"sphere_{a}_mm") for a in "xyz"]
    if any(have) and not all(have):
        missing = f"sphere_{'xyz'[have.index(False)]}_mm"
        raise t.error(f"a sphere position needs sphere_x_mm, sphere_y_mm and sphere_z_mm; "
                      f"{missing} is missing", None, missing)
    S = (np.column_stack([np.asarray(t[f"sphere_{a}_mm"], dtype=float) for a in "xyz"])
         if all(have) else np.full((n, 3), np.nan))
    part = np.isnan(S).any(axis=1) & ~np.isnan(S).all(axis=1)
    if part.any():
        i = int(np.flatnonzero(part)[0])
        col = f"sphere_{'xyz'[int(np.flatnonzero(np.isnan(S[i]))[0])]}_mm"
        raise t.error("give the sphere's three coordinates, or none (the test's sphere)", i,
                      col)
    names = ([str(v) for v in t["candidate"]] if t.has("candidate") else [""] * n)
    names = [v if v else f"row {int(t.rows[i])}" for i, v in enumerate(names)]
    base = nominal.with_location(np.zeros(len(location_parameter_names(nominal.chain_obj))))
    b0 = blocks[0]
    out: list[Candidate] = []
    for name in dict.fromkeys(names):
        idx = [i for i, v in enumerate(names) if v == name]
        s = S[idx[0]]
        if not np.allclose(np.nan_to_num(S[idx], nan=1e300), np.nan_to_num(s, nan=1e300)):
            raise t.error(f"candidate {name!r}: one sphere position per candidate", idx[1],
                          "sphere_x_mm")
        ang = {r.upper(): np.array([float(t[f"{r}_deg"][i]) for i in idx]) for r in letters}
        own = bool(np.isnan(s).any())
        sphere, pos = (b0.sphere, b0.sphere_mm) if own else (f"candidate:{name}", s)
        words = f"sphere {sphere} {_axis_words(nominal, pos)}" if own else (
            f"a sphere at ({', '.join(f'{v:g}' for v in pos)}) mm, "
            f"{_axis_words(nominal, pos)}")
        label = (_pose_label({r: float(a[0]) for r, a in ang.items()}, sphere)
                 if len(idx) == 1 and own else f"{name}: {len(idx)} pose(s), {words}")
        out.append(Candidate(label, "pose" if own else "sphere",
                             (_one(b0, base, ang, sphere, pos),), words))
    return out


# -- ranking -----------------------------------------------------------------------------
def _angle_words(c: Candidate, design: Sequence[SphereReadings], nominal: FiveAxisMachine
                 ) -> str:
    """How far the candidate's angles lie from the design's, in words."""
    if c.kind != "pose" or c.n_poses != 1:
        return c.where
    words = []
    for r, a in c.blocks[0].angles.items():
        have = np.concatenate([b.angles[r] for b in design])
        d = np.abs(have - float(a[0]))
        if nominal.rotary[r].full_circle:
            d = np.minimum(d % 360.0, 360.0 - d % 360.0)
        dmin = float(d.min()) if d.size else math.inf
        if dmin > 1e-9:
            words.append(f"{r} {float(a[0]):g}° is {dmin:g}° from the design's nearest {r} "
                         "angle")
    return "; ".join(words + [c.where]) if words else f"a new combination of angles; {c.where}"


def _reason(c: Candidate, new: Sequence[str], lost: Sequence[str], U0: dict[str, float],
            U1: dict[str, float], pair: tuple[str, str, float], sv1: float, geometry: str
            ) -> str:
    parts = []
    if new:
        parts.append(f"determines {', '.join(new)} (held at zero before)")
    if lost:
        parts.append(f"in place of {', '.join(lost)}")
    drops = sorted(((U0[n] - U1[n]) / U0[n], n) for n in U1 if n in U0 and U0[n] > 0)[::-1]
    said = [f"U of {n} {U0[n]:.3g} -> {U1[n]:.3g} {info(n).unit}" for f, n in drops[:2]
            if f >= 0.05]
    parts += said
    a, b, sv0 = pair
    if sv0 > 0 and sv1 > 1.1 * sv0:
        parts.append(f"adds {a}-{b} separation (the design's worst-separated combination, "
                     f"relative singular value {sv0:.2g} -> {sv1:.2g})")
    if not parts and drops:
        f, n = drops[0]
        parts.append(f"adds little: U of {n} {U0[n]:.3g} -> {U1[n]:.3g} {info(n).unit} "
                     f"({100 * f:.0f} %), the largest fall")
    elif not parts:
        parts.append("adds nothing the design does not determine")
    return "; ".join(parts) + f": {geometry}"


def rank_candidates(nominal: FiveAxisMachine, blocks: Sequence[SphereReadings],
                    candidates: Sequence[Candidate] | None = None, *, top: int | None = 10,
                    measurements: Sequence[str] = (), source: str = "generated",
                    ranges: Mapping[str, tuple[float, float]] | None = None) -> PoseRanking:
    """Rank candidate poses and sphere positions by what they add to the location errors.

    Parameters
    ----------
    nominal : FiveAxisMachine
        The configured machine (chain, nominal pivots, linear errors).
    blocks : sequence of SphereReadings
        The design (poses, spheres, tool offsets, noise; values unused).
    candidates : sequence of Candidate, optional
        Default :func:`default_candidates`.
    top : int or None
        How many to keep (None: all).
    measurements : sequence of str
        The design's test ids (for the record).
    source : str
        Where the candidates came from (for the record).
    ranges : mapping, optional
        Axis ranges of the generated candidates [deg].

    Returns
    -------
    PoseRanking
    """
    if not blocks:
        raise VolcalInputError("no probe_sphere poses to rank candidates for")
    names = list(location_parameter_names(nominal.chain_obj))
    base = nominal.with_location(np.zeros(len(names)))
    cands = list(candidates) if candidates is not None else default_candidates(
        nominal, blocks, ranges)
    chain = base.chain_obj
    d0 = _rows(base, blocks)
    rep0 = analyse_location(d0[0], d0[1], names, d0[2], chain)
    X0 = _eliminated(d0[0], d0[1])
    ld0 = _logdet(X0, names)
    U0 = _U(X0, names, rep0.free)
    pair = _worst_pair(X0, names, rep0.free) if len(rep0.free) > 1 else ("", "", 0.0)
    # the rows of the single-pose candidates of one sphere, computed at once
    cache: dict[int, tuple[Array, Array, list[str]]] = {}
    singles: dict[tuple[str, str, str], list[int]] = {}
    for i, c in enumerate(cands):
        if c.n_poses == 1 and len(c.blocks) == 1:
            b = c.blocks[0]
            singles.setdefault((b.id, b.kind, b.sphere), []).append(i)
    for idx in singles.values():
        bs = [cands[i].blocks[0] for i in idx]
        letters = list(bs[0].angles)
        ang = {r: np.concatenate([b.angles[r] for b in bs]) for r in letters}
        q = None if bs[0].q_mm is None else np.vstack([b.q_mm for b in bs])  # type: ignore[misc]
        big = SphereReadings(bs[0].id, bs[0].kind, ang, np.zeros((len(bs), 3)), bs[0].sphere,
                             bs[0].sphere_mm, bs[0].tool_offset_mm, q, bs[0].noise_um)
        Jx, Jn, nn = _rows(base, [big])
        for k, i in enumerate(idx):
            cache[i] = (Jx[3 * k:3 * k + 3], Jn[3 * k:3 * k + 3], nn)
    scored = []
    for i, c in enumerate(cands):
        part = cache.get(i) or _rows(base, list(c.blocks))
        Jx, Jn, nn = _stack([d0, part])
        rep = analyse_location(Jx, Jn, names, nn, chain)
        X = _eliminated(Jx, Jn)
        gain = _logdet(X, names) - ld0
        U1 = _U(X, names, rep.free)
        new = tuple(n for n in rep.free if n not in rep0.free)
        lost = tuple(n for n in rep0.free if n not in rep.free)
        sv1 = 0.0
        if pair[0] and pair[0] in rep.free and pair[1] in rep.free:
            Xf = X[:, [names.index(n) for n in rep.free]]
            Xf = Xf / np.maximum(np.linalg.norm(Xf, axis=0), 1e-300)
            s = np.linalg.svd(Xf, compute_uv=False)
            sv1 = float(s[-1] / s[0])
        scored.append((len(new) - len(lost), gain / max(c.n_poses, 1), gain, i, new, lost,
                       U1, sv1))
    scored.sort(key=lambda t: (-t[0], -t[1], t[3]))
    keep = scored if top is None else scored[:max(int(top), 0)]
    ranked = []
    for rank, (_, gpp, gain, i, new, lost, U1, sv1) in enumerate(keep, start=1):
        c = cands[i]
        geometry = _angle_words(c, blocks, base)
        b = c.blocks[0]
        ranked.append(RankedCandidate(
            rank, c.label, c.kind, c.where, c.n_poses,
            {r: [float(v) for v in np.concatenate([x.angles[r] for x in c.blocks])]
             for r in b.angles},
            [float(v) for v in b.sphere_mm], new, float(gain), float(gpp), U1,
            _reason(c, new, lost, U0, U1, pair, sv1, geometry)))
    return PoseRanking(chain.code, tuple(measurements), rep0.free, rep0.fixed, U0,
                       tuple(ranked), len(cands), source)
