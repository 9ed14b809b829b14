"""Shared builders of the report tests on direct optics (not named conftest: other test
folders import their own conftest by name)."""

from __future__ import annotations

import tomllib

import numpy as np

from volcal.plan.planner import plan_session
from volcal.session.format import Session
from volcal.uncertainty.budget import TEMPLATE, Budget, parse_budget

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def hand_session(scale: float = 1.0, name: str = "hand",
                 u_square_urad: float | None = 2.5) -> Session:
    """str-xy 0, 2, 1, 3 um (x scale), str-yx 0, 1, 2, 3 um, level 0, -4, 2.5, 1 urad (x
    scale) at 0, 100, 200, 300 mm; the optical square 'xy' deviates by 1 urad (certificate,
    u ``u_square_urad``; None: not stated, the budget's default)."""
    s = plan_session(TRAVEL, "XYFZ", 3, ("direct",), runs=1, iso_spacing=False,
                     linear_margin_mm=0.0)
    ms = [m for m in s.measurements if m.id in {"str-xy", "str-yx", "lev-xa"}]
    for m in ms:
        m.columns = {}
        m.positions = m.positions[:4]
        m.positions[:, m.axis] = [0.0, 100.0, 200.0, 300.0]
    by = {m.id: m for m in ms}
    by["str-xy"].deviation = scale * np.array([0.0, 2.0, 1.0, 3.0])
    by["str-yx"].deviation = np.array([0.0, 1.0, 2.0, 3.0])
    by["lev-xa"].deviation = scale * np.array([0.0, -4.0, 2.5, 1.0])
    square = {"square_deviation_urad": 1.0}
    if u_square_urad is not None:
        square["u_square_urad"] = u_square_urad
    return Session(name, "XYFZ", TRAVEL, ms, references={"xy": square})


def hand_budget() -> Budget:
    """The template budget with straightness 0.5 %, 0.3 um and level 1 %, 0.5 urad."""
    doc = tomllib.loads(TEMPLATE)
    doc["optics"] = {"u_straightness_scale_pct": 0.5, "u_straightness_um": 0.3,
                     "u_level_scale_pct": 1.0, "u_level_urad": 0.5}
    return parse_budget(doc)
