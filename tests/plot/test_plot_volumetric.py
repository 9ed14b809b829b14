import numpy as np

from volcal.model.errorfunctions import MachineErrors
from volcal.plot import volumetric_map, volumetric_map_plot

TRAVEL = np.array([[0, 800], [0, 600], [0, 500]], float)


def test_squareness_only_machine_hand_values():
    # EC0Y = 100 urad: e_x = -EC0Y * y; EB0Z = 50 urad: e_x += EB0Z * z;
    # EA0Z = -20 urad: e_y = -EA0Z * z   (docs/conventions.md)
    m = MachineErrors.zero("XYFZ", TRAVEL)
    m.squareness = np.array([100.0, 50.0, -20.0])
    vm = volumetric_map(m, nx=5, ny=4, z=[0.0, 500.0])
    assert vm.error.shape == (2, 4, 5, 3)
    # corner x=800, y=600, z=500: e_x = -100e-6*600e3 um + 50e-6*500e3 um = -60 + 25
    np.testing.assert_allclose(vm.error[1, -1, -1], [-35.0, 10.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(vm.error[0, 2, 3], [-100e-3 * 400.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(vm.length[1, -1, -1], np.hypot(35.0, 10.0))


def test_arrows_and_colours_are_the_error():
    m = MachineErrors.zero("XYFZ", TRAVEL)
    m.values[0][:, 1] = [0.0, 8.0]  # EYX: straightness of X in Y, 0 -> 8 um over X travel
    m.squareness = np.array([30.0, 0.0, 0.0])
    vm = volumetric_map(m, nx=3, ny=3, z=[100.0])
    fig = volumetric_map_plot(vm)
    quiv = [c for c in fig.axes[0].collections if c.get_gid() == "slice 0"][0]
    np.testing.assert_allclose(quiv.U.ravel(), vm.error[0, ..., 0].ravel())
    np.testing.assert_allclose(quiv.V.ravel(), vm.error[0, ..., 1].ravel())
    np.testing.assert_allclose(quiv.get_array().ravel(), vm.length[0].ravel())
    # EYX at x = 400 mm is 4 um (linear between nodes), independent of y
    np.testing.assert_allclose(vm.error[0, :, 1, 1], 4.0)
    assert any("|e| [µm]" in ax.get_ylabel() for ax in fig.axes)
