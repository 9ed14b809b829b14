"""The virtual machine and the session simulator: noise, drift, reversal, set-up, truth."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine, only
from volcal.measure.readings import SetupErrors, reading_exact
from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.plan.planner import plan_session


def _session(tests=("step-diagonal", "diagonal", "linear"), runs=2, steps=5):
    return plan_session(TRAVEL, "XYFZ", steps=steps, tests=tests, runs=runs)


def test_noiseless_simulation_is_the_exact_reading():
    s = _session()
    m = machine("XYFZ", seed=2)
    setups = simulate_session(s, m, SimulationOptions(noise_um=0.0, mirror_misalignment_urad=0.0))
    for ms in s.measurements:
        np.testing.assert_allclose(ms.deviation, reading_exact(m, ms, setups[ms.id]), atol=1e-12)
        assert ms.deviation[0] == 0.0
        np.testing.assert_allclose(ms.columns["time_s"], np.arange(ms.n) * 4.0)


def test_mirror_misalignment_drawn_perpendicular_to_the_beam():
    s = _session(tests=("step-diagonal", "diagonal"))
    setups = simulate_session(s, machine("XYFZ"), SimulationOptions(mirror_misalignment_urad=20.0))
    for ms in s.measurements:
        tilt = setups[ms.id].mirror_tilt
        if ms.target == "flat_mirror":
            assert np.linalg.norm(tilt) == pytest.approx(20.0)
            assert tilt @ ms.beam_direction == pytest.approx(0.0, abs=1e-9)
        else:
            np.testing.assert_array_equal(tilt, 0.0)


def test_reversal_applies_to_negative_approach_only():
    """A reversal r: '-' readings read -r against the '+' readings (ISO 230-2 B)."""
    s = _session(tests=("linear",), runs=2)
    m = machine("XYFZ").scaled(0.0)
    m.reversal[:] = [4.0, 6.0, 2.0]
    simulate_session(s, m, SimulationOptions(noise_um=0.0, mirror_misalignment_urad=0.0))
    for ms in s.measurements:
        k = ms.axis
        minus = ms.direction == "-"
        np.testing.assert_allclose(ms.deviation[~minus], 0.0, atol=1e-9)
        np.testing.assert_allclose(ms.deviation[minus], -m.reversal[k], atol=1e-6)


def test_linear_drift():
    s = _session(tests=("diagonal",))
    simulate_session(s, only(machine("XYFZ"), {}), SimulationOptions(
        noise_um=0.0, mirror_misalignment_urad=0.0, drift_um_per_h=3.6, dwell_s=10.0))
    for ms in s.measurements:
        np.testing.assert_allclose(ms.deviation, 0.01 * np.arange(ms.n), atol=1e-9)


def test_noise_level_and_reproducibility():
    s = _session(tests=("linear",), runs=5, steps=20)
    m = only(machine("XYFZ"), {})
    simulate_session(s, m, SimulationOptions(noise_um=0.5, mirror_misalignment_urad=0.0, seed=1))
    d = np.concatenate([ms.deviation[1:] for ms in s.measurements])
    # deviation = noise - noise[0]: std sqrt(0.5^2 + var of one draw per file) ~ 0.5..0.71
    assert 0.45 < d.std() < 0.75
    first = [ms.deviation.copy() for ms in s.measurements]
    simulate_session(s, m, SimulationOptions(noise_um=0.5, mirror_misalignment_urad=0.0, seed=1))
    for ms, f in zip(s.measurements, first, strict=True):
        np.testing.assert_array_equal(ms.deviation, f)


def test_truth_files_roundtrip(tmp_path):
    from volcal.session.errortable import read_error_table

    m = machine("YFXZ", seed=5)
    setups = {"a": SetupErrors(np.array([1.0, 2.0, 3.0]), np.zeros(3))}
    files = truth_files(m, setups, SimulationOptions())
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    back = read_error_table(tmp_path / "truth" / "machine.csv")
    assert str(back.chain) == "YFXZ"
    for k in range(3):
        np.testing.assert_allclose(back.values[k], m.values[k], atol=1e-6)
        np.testing.assert_allclose(back.nodes[k], m.nodes[k], rtol=1e-6)
    np.testing.assert_allclose(back.squareness, m.squareness)


def test_simulation_refuses_poses_against_the_beam():
    """Rows out of order (the first pose in the middle of a diagonal): the virtual laser,
    aligned from the first to the farthest pose, would read metres; the simulator refuses
    instead of writing a file its own reader rejects (found by the session fuzz test)."""
    from volcal.errors import VolcalInputError

    s = _session(tests=("diagonal",), steps=2)
    d = s.get("diag-npp")
    d.positions = d.positions[[1, 0, 2]].copy()
    with pytest.raises(VolcalInputError) as exc:
        simulate_session(s, machine("XYFZ"))
    assert exc.value.file == "diag-npp.csv" and exc.value.row == 3
    assert exc.value.message.endswith("um is absurd (> 10000 um): the poses of 'diag-npp' do "
                                      "not run from the first row along its beam direction "
                                      "(rows out of order?)")
