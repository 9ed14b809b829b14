"""LinuxCNC's installed trt kinematics decide: volcal's pins and angle sign against the binary.

The module ``xyzac-trt-kins.so`` / ``xyzbc-trt-kins.so`` of the installed LinuxCNC (Debian
``linuxcnc-uspace``) is loaded in-process with a small stub of the HAL/RTAPI functions it
imports (``nm -D --undefined-only``: ``hal_init``, ``hal_malloc``, ``hal_pin_float_newf``
...), compiled here with gcc; the stub keeps each pin's storage by name, so a ``setp`` line
of volcal's HAL file sets the value the module's own ``kinematicsForward`` reads.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from volcal.compensate.linuxcnc_trt import trt_export, trt_hal, trt_pins
from volcal.measure.fiveaxis_virtual import nominal_machine, pose_grid
from volcal.measure.spheres import SphereReadings
from volcal.model.fiveaxis import exact_pose5

MODULES = Path("/usr/lib/linuxcnc/modules")
STUB = r"""
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#define MAXP 128
static char names[MAXP][96];
static double *fptr[MAXP];
static int np_ = 0;
int hal_init(const char *name) { return 1; }
int hal_ready(int id) { return 0; }
int hal_exit(int id) { return 0; }
void *hal_malloc(long size) { return calloc(1, size); }
int hal_pin_float_newf(int dir, double **p, int comp_id, const char *fmt, ...) {
    va_list ap; va_start(ap, fmt); vsnprintf(names[np_], 96, fmt, ap); va_end(ap);
    *p = calloc(1, sizeof(double)); fptr[np_++] = *p; return 0; }
int hal_pin_bit_new(const char *n, int d, void **p, int c) { *p = calloc(1, 8); return 0; }
int hal_pin_s32_new(const char *n, int d, void **p, int c) { *p = calloc(1, 8); return 0; }
void rtapi_print(const char *fmt, ...) {}
void rtapi_print_msg(int level, const char *fmt, ...) {}
int stub_set(const char *name, double v) {
    /* the latest pin of that name: the module's own after a second rtapi_app_main */
    for (int i = np_ - 1; i >= 0; i--) if (!strcmp(names[i], name)) { *fptr[i] = v; return 0; }
    return -1; }
"""


@pytest.fixture(scope="module")
def stub(tmp_path_factory):
    if shutil.which("gcc") is None or not (MODULES / "xyzac-trt-kins.so").is_file():
        pytest.skip("needs gcc and LinuxCNC's modules (make linuxcnc-deps)")
    d = tmp_path_factory.mktemp("halstub")
    (d / "stub.c").write_text(STUB)
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(d / "libstub.so"), str(d / "stub.c")],
                   check=True, capture_output=True)
    return ctypes.CDLL(str(d / "libstub.so"), mode=ctypes.RTLD_GLOBAL)


class Kins:
    """One installed trt module, its pins set by ``setp`` lines."""

    _loaded: dict[str, ctypes.CDLL] = {}

    def __init__(self, stub, name):
        self.stub, self.name = stub, name
        if name not in Kins._loaded:  # one rtapi_app_main per module and process
            lib = ctypes.CDLL(str(MODULES / f"{name}.so"))
            assert lib.rtapi_app_main() == 0
            Kins._loaded[name] = lib
        self.lib = Kins._loaded[name]

    def setp(self, hal_text):
        for line in hal_text.splitlines():
            if line.startswith("setp "):
                _, pin, value = line.split()
                assert self.stub.stub_set(pin.encode(), ctypes.c_double(float(value))) == 0, pin

    def forward(self, joints):
        """World (workpiece) coordinates of the tool from joints X Y Z A|B C (coordinates
        XYZAC or XYZBC: joints 0-4)."""
        J = (ctypes.c_double * 16)(*(list(joints) + [0.0] * (16 - len(joints))))
        pos = (ctypes.c_double * 9)()
        f, i = ctypes.c_ulong(0), ctypes.c_ulong(0)
        assert self.lib.kinematicsForward(J, pos, ctypes.byref(f), ctypes.byref(i)) == 0
        return np.array(pos[:3])


@pytest.mark.parametrize(("code", "kins"), [("CAFXYZ", "xyzac-trt-kins"),
                                            ("CBFXYZ", "xyzbc-trt-kins")])
def test_installed_kinematics_with_volcals_pins_is_volcals_model(stub, code, kins):
    """Pins from a machine whose lines are off by mm (no tilt): LinuxCNC's forward
    kinematics equals volcal's exact pose, with volcal's angle = minus the joint's."""
    rng = np.random.default_rng(4)
    second = code[1]
    m = nominal_machine(code, {"C": [200.0, 150.0, 10.0], second: [200.0, 150.0, -110.0]})
    names = [n for r in ("C", second) for n in m.rotary[r].location_names]
    m = m.with_location([rng.uniform(-2000, 2000) if i % 5 < 2 else 0.0
                         for i, _ in enumerate(names)])
    name, pins = trt_pins(m, z_rot_point_mm=-37.0)
    assert name == kins
    k = Kins(stub, kins)
    k.setp("\n".join(f"setp {kins}.{p} {v:.9f}" for p, v in pins.items()))
    for _ in range(10):
        q = rng.uniform(-300, 300, 3)
        a, c = rng.uniform(-120, 120), rng.uniform(-360, 360)
        world = k.forward([*q, a, c])
        p, _ = exact_pose5(m, q, {"C": -c, second: -a})
        np.testing.assert_allclose(world, p[0], atol=1e-8)
        # and the opposite sign is not it
        wrong, _ = exact_pose5(m, q, {"C": c, second: a})
        assert np.abs(world - wrong[0]).max() > 1e-3


def test_hal_file_and_the_residual_of_a_tilt(stub):
    """A tilt the kinematics cannot hold: named in the HAL file, with the scatter it leaves;
    without tilts the predicted scatter is nil."""
    code = "CAFXYZ"
    m = nominal_machine(code, {"C": [200.0, 150.0, 10.0], "A": [200.0, 150.0, -110.0]})
    ang = pose_grid(code)
    n = ang["C"].size
    blocks = [SphereReadings("p", "probe", ang, np.zeros((n, 3)), "S1",
                             np.array([350.0, 150.0, 50.0]), np.zeros(3))]
    spheres = {"S1": [350.0, 150.0, 50.0]}
    ident = m.with_location([800.0, -500.0, 0.0, 0.0, 0.0, 1200.0, 300.0, 0.0, 0.0, 0.0])
    exp = trt_export(ident, blocks, spheres, configured=m)
    assert exp.residual_um.max() < 1e-6 and exp.scatter_before_um.max() > 500.0
    assert not exp.not_held
    tilted = ident.with_location([800.0, -500.0, 50.0, 0.0, 0.0, 1200.0, 300.0, 0.0, 0.0, 0.0])
    exp = trt_export(tilted, blocks, spheres, configured=m)
    assert exp.not_held == {"EA0C": 50.0}
    # 50 urad of C's tilt about X acting on the sphere 40 mm above C's pivot plane and
    # 150 mm off its axis: a scatter of a few um that the pins cannot remove
    assert 1.0 < exp.residual_um.max() < 30.0
    text = trt_hal(exp)
    assert "EA0C = 50.0" in text and "setp xyzac-trt-kins.x-rot-point 200.800000" in text
    k = Kins(stub, "xyzac-trt-kins")
    k.setp(text)  # every pin volcal writes exists in the installed module


@pytest.mark.parametrize("tilt", [False, True])
def test_identified_pins_close_the_loop_through_the_installed_kinematics(stub, tilt):
    """Probe readings of a machine whose lines are off by up to 2 mm: with volcal's pins,
    LinuxCNC's own kinematics maps the reported centres of every pose onto one sphere
    centre within 2 um (it scattered by millimetres with the configured pins); with tilts
    it cannot hold, the scatter LinuxCNC computes is the residual volcal predicted."""
    from volcal.compensate.linuxcnc_trt import trt_pins
    from volcal.identify.location import identify_location
    from volcal.measure.fiveaxis_virtual import random_location
    from volcal.measure.spheres import simulate_blocks
    from volcal.model.fiveaxis import location_parameter_names
    from volcal.steps.locate import Located

    rng = np.random.default_rng(28 + tilt)
    code = "CAFXYZ"
    nominal = nominal_machine(code, {"C": [200.0, 150.0, 10.0], "A": [200.0, 150.0, -110.0]})
    names = location_parameter_names(code)
    truth = random_location(code, rng)
    truth = {n: (v if n[1] in "XYZ" or (tilt and n in ("EA0C", "EB0A")) else 0.0)
             for n, v in truth.items()}
    true_m = nominal.with_location([truth[n] for n in names])
    ang = pose_grid(code)
    n = ang["C"].size
    design = [SphereReadings("p", "probe", ang, np.zeros((n, 3)), "S1",
                             np.array([350.0, 150.0, 50.0]), np.zeros(3))]
    data = simulate_blocks(true_m, design, {"S1": [350.4, 149.7, 50.2]}, rng)
    res = identify_location(nominal, data)
    # the control probes again: the centres it reports (without the noise of one probing)
    again = simulate_blocks(true_m, design, {"S1": [350.4, 149.7, 50.2]}, rng, noise_scale=0.0)
    exp = Located(res, code, ("p",), (), tuple(data)).linuxcnc_trt()

    def scatter(hal):
        k = Kins(stub, "xyzac-trt-kins")
        k.setp(hal)
        w = np.array([k.forward([*again[0].values[i], -ang["A"][i], -ang["C"][i]])
                      for i in range(n)])
        return np.linalg.norm(w - w.mean(axis=0), axis=1) * 1e3

    _, configured = trt_pins(nominal)
    before = scatter("\n".join(f"setp xyzac-trt-kins.{p} {v:.6f}"
                               for p, v in configured.items()))
    after = scatter(trt_hal(exp))
    assert before.max() > 500.0
    if not tilt:
        # the identified tilts are noise (a few urad): a predicted residual below 2 um too
        assert after.max() < 2.0 and exp.residual_um.max() < 2.0
    else:
        assert after.max() > 5.0  # what the pins cannot hold
        np.testing.assert_allclose(after, exp.residual_um, atol=2.0)  # as volcal predicted
