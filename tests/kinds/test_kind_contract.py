"""The contract every registered measurement kind passes (``docs/architecture.md``).

For each kind of the registry (:func:`volcal.kinds.kinds`), on measurements it plans itself:

* its forward model and its Jacobian rows agree to first order: the exact readings of a
  virtual machine (:meth:`Kind.exact`, perfect set-up) equal the rows applied to the
  machine's parameters (:meth:`Kind.rows`), the difference shrinking as the square of the
  errors (second order);
* its reader gives back what its writer wrote (session round trip);
* bad input is refused naming the file and the key or column.

A kind registered later (``tests/kinds/test_kind_plugin.py``) runs the same checks through
:func:`check_kind_contract`.
"""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.identify.design import choose_nodes
from volcal.kinds import Kind, kind_names, kind_of
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.chain import parse_chain
from volcal.model.parameters import ParameterLayout
from volcal.plan.planner import plan_session
from volcal.session.format import Session, read_session, write_session

TRAVEL = np.array([[0.0, 400.0], [0.0, 300.0], [0.0, 200.0]])
BUILTIN = ("linear", "diagonal", "step_diagonal", "multilateration", "straightness", "angular",
           "rotary")


def planned_session(kind: Kind, chain: str = "XYFZ", **plan_kw) -> Session:
    """A small session of the kind's own plan tests, with only the kind's measurements."""
    tests = kind.plan_tests or ("direct",)  # the angular optics are planned with "direct"
    s = plan_session(TRAVEL, chain, steps=4, tests=tests, runs=2, name="contract",
                     multilateration={"grid": (3, 3, 2), "n_stations": 3}, **plan_kw)
    ms = [m for m in s.measurements if m.kind == kind.name]
    assert ms, f"kind {kind.name!r}: its plan tests {tests} plan none of its measurements"
    refs = {m.meta.get("reference") for m in ms}
    return Session(s.name, s.chain, s.travel, ms, s.meta,
                   references={k: v for k, v in s.references.items() if k in refs})


def first_order_gap(kind: Kind, session: Session, scale: float, seed: int = 5) -> tuple:
    """Largest |exact - rows @ truth| and largest |exact| over the session [reading unit]."""
    machine = random_machine(session.travel, session.chain, seed=seed).scaled(scale)
    kind.prepare(session)
    nodes = choose_nodes(session)
    layout = ParameterLayout(tuple(np.asarray(n, dtype=float) for n in nodes))
    theta = layout.pack(machine)
    order = parse_chain(session.chain).order
    gap, peak = 0.0, 0.0
    for m in session.measurements:
        exact = kind.exact(machine, m)
        m.deviation = exact - exact[0]
        J, y, N, names = kind.rows(order, layout.nodes, m)
        assert J.shape == (m.n, layout.size) and N.shape[0] == m.n and len(names) == N.shape[1]
        w = kind.row_weight(m)
        np.testing.assert_allclose(y / w, m.deviation, rtol=0, atol=1e-9)
        pred = (J @ theta) / w
        gap = max(gap, float(np.max(np.abs(m.deviation - pred))))
        peak = max(peak, float(np.max(np.abs(m.deviation))))
    return gap, peak


def check_first_order(kind: Kind, session_factory) -> None:
    """Rows applied to the truth equal the exact readings to first order."""
    gap1, peak1 = first_order_gap(kind, session_factory(), 1.0)
    gap2, peak2 = first_order_gap(kind, session_factory(), 2.0)
    assert peak1 > 0.5, f"{kind.name}: the readings do not see the machine ({peak1:g})"
    assert peak2 == pytest.approx(2 * peak1, rel=0.05)  # first order: linear in the errors
    assert gap1 < 2e-3 * peak1 + 1e-9, f"{kind.name}: first order off by {gap1:g} of {peak1:g}"
    # what is left is second order: four times as large for errors twice as large
    if gap1 > 1e-9:
        assert 3.0 < gap2 / gap1 < 5.0, f"{kind.name}: gap {gap1:g} -> {gap2:g}"


def check_round_trip(kind: Kind, session: Session, tmp_path) -> Session:
    """Simulate, write, read back: the same measurements."""
    machine = random_machine(session.travel, session.chain, seed=2)
    simulate_session(session, machine, SimulationOptions(seed=4))
    write_session(session, tmp_path / "s")
    back = read_session(tmp_path / "s")
    assert [m.id for m in back.measurements] == [m.id for m in session.measurements]
    for a, b in zip(session.measurements, back.measurements, strict=True):
        assert (b.kind, b.target, b.file) == (a.kind, a.target, a.file)
        np.testing.assert_allclose(b.positions, a.positions, atol=1e-6)
        np.testing.assert_allclose(b.tool_offset, a.tool_offset, atol=1e-6)
        np.testing.assert_allclose(b.deviation, a.deviation, atol=2e-5)  # CSV decimals
        assert np.max(np.abs(a.deviation)) > 0.1
        for c in ("run", "direction"):
            assert (c in b.columns) == (c in a.columns)
            if c in a.columns:
                assert list(b.columns[c]) == list(a.columns[c])
        assert {k: v for k, v in b.meta.items() if not k.startswith("_")} == \
            {k: v for k, v in a.to_toml().items() if k not in (
                "id", "kind", "target", "file", "tool_offset_mm", "beam_direction")} | \
            {k: v for k, v in b.meta.items() if k == "station_mm"}
        if kind.beam_in_session:
            np.testing.assert_allclose(b.beam_direction, a.beam_direction, atol=1e-12)
    return back


def check_refusals(kind: Kind, folder) -> None:
    """A wrong target, a missing file key, a renamed reading column: file and key named."""
    toml = folder / "session.toml"
    text = toml.read_text()
    m0 = read_session(folder).measurements[0]
    first = f'target = "{m0.target}"'
    assert first in text
    toml.write_text(text.replace(first, 'target = "no_such_target"', 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert exc.value.file == str(toml) and exc.value.column == "measurements[0].target"
    assert "unknown target 'no_such_target': expected one of" in exc.value.message
    toml.write_text(text.replace(f'file = "{m0.file}"', 'files = "x.csv"', 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert (exc.value.file, exc.value.column) == (str(toml), "measurements[0].file")
    toml.write_text(text)
    csv = folder / m0.file
    csv.write_text(csv.read_text().replace(kind.value_column, "reading", 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert exc.value.file == str(csv) and kind.value_column in str(exc.value)


def session_for(kind_name: str, chain: str = "XYFZ"):
    """Factory of a fresh planned session of one kind on the chain ``chain``."""
    return lambda: planned_session(kind_of(kind_name), chain)


def test_the_builtin_kinds_are_registered_in_their_documented_order():
    assert kind_names()[:7] == BUILTIN
    for name in BUILTIN:
        k = kind_of(name)
        assert k.name == name and k.targets and isinstance(k, Kind)
    with pytest.raises(VolcalInputError, match="unknown kind 'circle': expected one of linear, "
                       "diagonal, step_diagonal, multilateration, straightness, angular"):
        kind_of("circle")


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "YFXZ"])  # mill, gantry, other levers
@pytest.mark.parametrize("name", [n for n in kind_names() if kind_of(n).in_design])
def test_rows_are_the_first_order_of_the_forward_model(name, chain):
    check_first_order(kind_of(name), session_for(name, chain))


def test_kinds_outside_the_design_are_left_out_of_the_identification(tmp_path):
    """A kind with ``in_design = False`` (rotary) adds no row to the linear estimator."""
    from volcal.identify.design import build_design

    out = [n for n in kind_names() if not kind_of(n).in_design]
    assert out == ["rotary", "probe_sphere", "r_test"]
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("linear:x", "rotary:c"), runs=2)
    simulate_session(s, random_machine(s.travel, s.chain, seed=2), SimulationOptions(seed=4))
    design = build_design(s)
    assert [m.kind for m in design.measurements] == ["linear"] * 3


@pytest.mark.parametrize("name", kind_names())
def test_reader_round_trip(name, tmp_path):
    check_round_trip(kind_of(name), planned_session(kind_of(name)), tmp_path)


@pytest.mark.parametrize("name", kind_names())
def test_bad_input_is_refused_naming_file_and_key(name, tmp_path):
    kind = kind_of(name)
    check_round_trip(kind, planned_session(kind), tmp_path)
    check_refusals(kind, tmp_path / "s")
