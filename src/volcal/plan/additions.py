"""The extra measurements the identifiability report tries, as ``volcal plan --add`` options.

Each candidate is planned by :func:`volcal.plan.planner.plan_session` from the same
options the command line takes, so the tests ``volcal advise`` evaluates are exactly the
tests its printed command adds (``volcal plan --add S --tests diagonal --tool-offset
0,0,150``).
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from volcal.session.format import Measurement

__all__ = ["DEFAULT_STEPS", "Addition", "candidate_additions"]

DEFAULT_STEPS = 10
"""``volcal plan --steps`` default: left out of a printed command when equal."""


@dataclass(frozen=True)
class Addition:
    """One candidate extra measurement.

    Attributes
    ----------
    label : str
        Plain words (``'the 4 body diagonals with a tool offset of 150 mm in Z'``).
    tests : tuple of str
        ``--tests`` of ``volcal plan`` (``'diagonal'``, ``'linear:x'``).
    options : dict
        Further :func:`~volcal.plan.planner.plan_session` keywords: ``tool_offset``,
        ``step_orders``, ``step_target``.
    """

    label: str
    tests: tuple[str, ...]
    options: dict[str, Any] = field(default_factory=dict)

    def plan(self, travel: ArrayLike, chain: str, steps: int,
             vertical_axis: int = 2) -> list[Measurement]:
        """The planned measurements of this candidate (deviations empty).

        Parameters
        ----------
        travel : array_like, shape (3, 2)
            Travel [mm].
        chain : str
            Chain code.
        steps : int
            Increments per test.
        vertical_axis : int
            The machine's vertical axis (0, 1, 2), for direct optics (``volcal plan --add``
            takes it from the session's ``[machine] vertical_axis``).

        Returns
        -------
        list of Measurement
        """
        from volcal.plan.planner import plan_session

        return plan_session(travel, chain, steps, self.tests, vertical_axis=vertical_axis,
                            **self.options).measurements

    def arguments(self, steps: int) -> list[str]:
        """The ``volcal plan --add`` options after the folder.

        Parameters
        ----------
        steps : int
            Increments per test (``--steps`` is left out when it is the default).

        Returns
        -------
        list of str
        """
        out = ["--tests", ",".join(self.tests)]
        off = self.options.get("tool_offset")
        if off is not None and np.any(np.asarray(off) != 0):
            out += ["--tool-offset", ",".join(f"{float(v):g}" for v in off)]
        if "step_orders" in self.options:
            out += ["--step-orders", ",".join(self.options["step_orders"])]
        if "step_target" in self.options:
            out += ["--step-target", self.options["step_target"]]
        if steps != DEFAULT_STEPS:
            out += ["--steps", str(steps)]
        return out

    def command(self, folder: str | Path, steps: int) -> str:
        """The command line that adds this candidate to the session ``folder``.

        Parameters
        ----------
        folder : str or Path
            Session folder as the user names it.
        steps : int
            Increments per test.

        Returns
        -------
        str
            ``volcal plan --add S --tests diagonal --tool-offset 0,0,150``.
        """
        return shlex.join(["volcal", "plan", "--add", str(folder), *self.arguments(steps)])


def candidate_additions(travel: ArrayLike, vertical_axis: int = 2) -> list[Addition]:
    """The candidate extra measurements of the identifiability report.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel [mm]: the body diagonals' tool offset is a quarter of the Z travel.
    vertical_axis : int
        The machine's vertical axis (0, 1, 2): the direct optics read the roll of each
        other axis with a level, its own by its straightness at two tool offsets.

    Returns
    -------
    list of Addition
        The 3 linear lines of each axis, the step diagonals with a retroreflector, in
        axis order zyx, the body diagonals with a tool offset in Z, and the face
        diagonals of each plane, and the direct optics that read a roll
        (:func:`volcal.plan.optics.optic_additions`: ``--tests direct:level-x``,
        ``direct:roll-z``).
    """
    from volcal.plan.optics import optic_additions

    t = np.asarray(travel, dtype=float).reshape(3, 2)
    out = [Addition(f"the 3 linear lines of {a.upper()} (reference line and 2 Abbe offsets)",
                    (f"linear:{a}",)) for a in "xyz"]
    out.append(Addition("the 4 step diagonals with a retroreflector", ("step-diagonal",),
                        {"step_target": "retroreflector"}))
    out.append(Addition("the 4 step diagonals in axis order zyx", ("step-diagonal",),
                        {"step_orders": ("zyx",)}))
    dz = float(np.round(0.25 * (t[2, 1] - t[2, 0])))
    out.append(Addition(f"the 4 body diagonals with a tool offset of {dz:g} mm in Z",
                        ("diagonal",), {"tool_offset": (0.0, 0.0, dz)}))
    out += [Addition(f"the 2 face diagonals in {p.upper()}", (f"face-diagonal:{p}",))
            for p in ("xy", "yz", "xz")]
    out += [Addition(label, tests) for label, tests in optic_additions(vertical_axis)]
    return out
