"""Independent check of the 5-axis chain composition: a URDF of the same chain in pytransform3d.

The URDF is written from the documented meaning of every error (``docs/fiveaxis.md``), not
from volcal's code: a linear axis is a prismatic joint along its actual direction (the
squareness convention of ``docs/conventions.md``) followed by a fixed joint carrying its
component errors; a rotary axis' location errors are a revolute joint whose origin is the
actual point of the axis line (nominal pivot + position error) and whose axis is the
actual direction (the nominal one turned by the orientation rotation vector), turned by the
commanded angle plus the zero error, then a fixed joint back by the same point; its
component errors are a fixed joint at the nominal pivot, on the carrier's side. pytransform3d
composes the chain and returns the tool frame in the workpiece frame.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_fiveaxis import random_rotary

from volcal.model.chain import parse_machine_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.fiveaxis import exact_pose5

UrdfTransformManager = pytest.importorskip("pytransform3d.urdf").UrdfTransformManager


def _xyz(v) -> str:
    return " ".join(f"{x:.17g}" for x in v)


def _rpy(rotvec_rad) -> str:
    # URDF rpy: fixed axes, R = Rz(y) Ry(p) Rx(r) = scipy's extrinsic "xyz"
    return _xyz(Rotation.from_rotvec(rotvec_rad).as_euler("xyz"))


class _Urdf:
    def __init__(self):
        self.links = ["workpiece"]
        self.joints = []
        self.values = {}

    def joint(self, kind, origin=(0, 0, 0), rpy=(0, 0, 0), axis=None, value=None):
        parent = self.links[-1]
        child = f"l{len(self.links)}"
        name = f"j{len(self.links)}"
        self.links.append(child)
        rpy_s = rpy if isinstance(rpy, str) else _xyz(rpy)
        extra = ""
        if axis is not None:
            extra = (f'<axis xyz="{_xyz(axis)}"/><limit lower="-1e6" upper="1e6" '
                     'effort="1" velocity="1"/>')
            self.values[name] = value
        self.joints.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_xyz(origin)}" rpy="{rpy_s}"/>{extra}</joint>')

    def text(self):
        links = "".join(f'<link name="{n}"/>' for n in self.links)
        return f'<robot name="machine">{links}{"".join(self.joints)}</robot>'


def _linear_directions(sq_urad):
    """Actual X, Y, Z directions from EC0Y, EB0Z, EA0Z as docs/conventions.md defines them."""
    c0y, b0z, a0z = np.asarray(sq_urad) * 1e-6
    uy = Rotation.from_rotvec([0, 0, c0y]).apply([0, 1, 0])  # Y turned about Z by EC0Y
    uz = Rotation.from_rotvec([0, b0z, 0]).apply(Rotation.from_rotvec([a0z, 0, 0]).apply([0, 0, 1]))
    return np.array([[1, 0, 0], uy, uz])


def urdf_pose(m, q, angles, t):
    """Tool pose in the workpiece frame from a URDF of the chain, composed by pytransform3d."""
    chain = parse_machine_chain(m.chain.code)
    u = _linear_directions(m.linear.squareness)
    doc = _Urdf()
    for letter in chain.letters:
        if letter in "XYZ":
            k = "XYZ".index(letter)
            comp = m.linear.component(k, [q[k]])[0]
            doc.joint("prismatic", axis=u[k], value=q[k])
            doc.joint("fixed", origin=comp[:3] * 1e-3, rpy=_rpy(comp[3:] * 1e-6))
            continue
        ax = m.rotary[letter]
        e = np.eye(3)["ABC".index(letter)]
        names = ax.location_names
        across = [a for a in range(3) if a != "ABC".index(letter)]
        d, o = np.zeros(3), np.zeros(3)
        d[across], o[across] = [ax.location[names[0]], ax.location[names[1]]], \
            [ax.location[names[2]], ax.location[names[3]]]
        point = ax.pivot_mm + d * 1e-3
        direction = Rotation.from_rotvec(o * 1e-6).apply(e)
        angle = np.deg2rad(angles[letter]) + ax.location[names[4]] * 1e-6
        # component errors: the table is evaluated at a node, where it holds the node's row
        row = ax.values[list(ax.nodes_deg).index(angles[letter] % 360.0)]

        def location():
            doc.joint("revolute", origin=point, axis=direction, value=angle)  # noqa: B023
            doc.joint("fixed", origin=-point)  # noqa: B023

        def component():
            doc.joint("fixed", origin=ax.pivot_mm)  # noqa: B023
            doc.joint("fixed", origin=row[:3] * 1e-3, rpy=_rpy(row[3:] * 1e-6))  # noqa: B023
            doc.joint("fixed", origin=-ax.pivot_mm)  # noqa: B023

        if chain.on_workpiece_side(letter):  # the carrier is read after: location first
            location()
            component()
        else:
            component()
            location()
    doc.joint("fixed", origin=t)
    tm = UrdfTransformManager()
    tm.load_urdf(doc.text())
    for name, value in doc.values.items():
        tm.set_joint(name, value)
    return tm.get_transform(doc.links[-1], "workpiece")


@pytest.mark.parametrize("code", ("CAFXYZ", "BCFXYZ", "CFXYZB", "FXYZCA", "AFXYZC"))
def test_chain_composition_equals_urdf(code):
    """Random location errors (pivot 2 mm, tilts 200 urad), component and linear errors."""
    rng = np.random.default_rng(sum(map(ord, code)) + 1)
    chain = parse_machine_chain(code)
    lin = MachineErrors(chain.linear.code, [[0.0]] * 3,
                        [rng.normal(0, 5, (1, 6)) * [1, 1, 1, 10, 10, 10] for _ in range(3)],
                        rng.normal(0, 50, 3))
    m = random_rotary(code, rng, pivot_um=2000.0, tilt_urad=200.0, linear=lin)
    t = np.array([3.0, -4.0, 150.0])
    for _ in range(4):
        q = rng.uniform(-400, 400, 3)
        angles = {r: float(rng.choice(m.rotary[r].nodes_deg)) + 360.0 * rng.integers(-1, 2)
                  for r in chain.rotary}
        H = urdf_pose(m, q, angles, t)
        p, R = exact_pose5(m, q, angles, t)
        np.testing.assert_allclose(p[0], H[:3, 3], atol=1e-9)
        np.testing.assert_allclose(R[0], H[:3, :3], atol=1e-12)
