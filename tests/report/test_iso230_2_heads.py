"""The report's two tables of ISO 230-2 parameters (linear and rotary axes) head and
explain their columns alike.

Session 22: one report headed the linear axes' mean reversal "B̄ [µm]" and the rotary
axes' "B_mean [µrad]" (the Python name), each table with its own legend.
"""

from __future__ import annotations

from types import SimpleNamespace

from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.report.rotary import rotary_section
from volcal.report.sections import positioning_section
from volcal.standards.iso230_2 import evaluate

TRAVEL = [[0, 800], [0, 600], [0, 500]]


def _iso(m):
    return evaluate(m.positions[:, m.axis], m.columns["run"], m.direction, m.deviation)


def test_linear_and_rotary_tables_share_heads_and_legend():
    s = plan_session(TRAVEL, tests=["linear:x", "rotary:c"], steps=3, runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    lin = [m for m in s.measurements if m.kind == "linear"]
    inp = SimpleNamespace(session=s, evaluation=None, budget=None, result=None,
                          iso230_2={m.id: _iso(m) for m in lin},
                          iso230_2_uncertainty=None, angle_units="urad")
    (a,) = positioning_section(inp).tables[:1]
    (b, *_) = rotary_section(inp).tables
    heads = [h.replace(" [µm]", "") for h in a.columns[2:]]
    assert heads == ["A", "A↑", "A↓", "E", "M", "R", "R↑", "R↓", "B", "B̄"]
    assert [h.replace(" [µrad]", "") for h in b.columns[2:2 + len(heads)]] == heads
    assert a.note == b.note and "B̄ mean reversal value" in a.note
    assert not any("_" in h for h in b.columns)
