component volcal_trt_machine "volcal test machine: a hidden true table-rotary-tilting machine and a calibration sphere; drives the probe input when the true tool tip touches the sphere";

description """
The true machine of volcal's closed-loop test (tests/compensate/test_trt_closed_loop.py).
It reads the joint positions X Y Z, T (the tilting axis A or B) and C and computes where
the tool tip is in table (workpiece) coordinates with the geometry of LinuxCNC's own
xyzac-trt-kins / xyzbc-trt-kins (src/emc/kinematics/trtfuncs.c):

    world = R(c-dir, -c) [ R(t-dir, -t) (J - t-point) + t-point - c-point ] + c-point

but with the true lines: c-point / t-point a point of the C / tilting line, c-dir / t-dir
their directions (normalised here; a tilt is a direction off the nominal axis). The sphere
is fixed on the table: probe is TRUE while the tool tip (the probe's ball centre) is within
radius (sphere radius plus tip radius) of the sphere centre.
""";

pin in float joint_x "joint 0 position [mm]";
pin in float joint_y "joint 1 position [mm]";
pin in float joint_z "joint 2 position [mm]";
pin in float joint_t "joint 3 position, the tilting axis [deg]";
pin in float joint_c "joint 4 position, C [deg]";
pin in float c_point_x; pin in float c_point_y; pin in float c_point_z;
pin in float c_dir_x = 0.0; pin in float c_dir_y = 0.0; pin in float c_dir_z = 1.0;
pin in float t_point_x; pin in float t_point_y; pin in float t_point_z;
pin in float t_dir_x = 1.0; pin in float t_dir_y = 0.0; pin in float t_dir_z = 0.0;
pin in float sphere_x; pin in float sphere_y; pin in float sphere_z;
pin in float radius = 14.0 "contact distance of the tip centre from the sphere centre [mm]";
pin out bit probe "TRUE while the tip touches or is inside the sphere";
pin out float distance "tip centre to sphere centre minus radius [mm]";
pin out float world_x; pin out float world_y; pin out float world_z;

function _;
license "GPL";
;;

#include "rtapi_math.h"

/* v := R(u, ang) v, u a unit vector, right-hand rotation (Rodrigues) */
static void rot(const double u[3], double ang, double v[3]) {
    double c = cos(ang), s = sin(ang), d = u[0]*v[0] + u[1]*v[1] + u[2]*v[2];
    double x[3];
    x[0] = u[1]*v[2] - u[2]*v[1];
    x[1] = u[2]*v[0] - u[0]*v[2];
    x[2] = u[0]*v[1] - u[1]*v[0];
    for (int i = 0; i < 3; i++) v[i] = v[i]*c + x[i]*s + u[i]*d*(1.0 - c);
}

static void unit(double u[3]) {
    double n = sqrt(u[0]*u[0] + u[1]*u[1] + u[2]*u[2]);
    if (n > 0) { u[0] /= n; u[1] /= n; u[2] /= n; }
}

FUNCTION(_) {
    const double deg = M_PI / 180.0;
    double uc[3] = {c_dir_x, c_dir_y, c_dir_z}, ut[3] = {t_dir_x, t_dir_y, t_dir_z};
    double pc[3] = {c_point_x, c_point_y, c_point_z}, pt[3] = {t_point_x, t_point_y, t_point_z};
    double v[3] = {joint_x - pt[0], joint_y - pt[1], joint_z - pt[2]};
    double dx, dy, dz, d;
    unit(uc); unit(ut);
    rot(ut, -joint_t * deg, v);
    for (int i = 0; i < 3; i++) v[i] += pt[i] - pc[i];
    rot(uc, -joint_c * deg, v);
    world_x = v[0] + pc[0]; world_y = v[1] + pc[1]; world_z = v[2] + pc[2];
    dx = world_x - sphere_x; dy = world_y - sphere_y; dz = world_z - sphere_z;
    d = sqrt(dx*dx + dy*dy + dz*dz) - radius;
    distance = d;
    probe = d <= 0.0;
}
