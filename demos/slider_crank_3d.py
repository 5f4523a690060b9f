# # Spatial rigid slider-crank under gravity (IFToMM benchmark)
#
# A crank turns about the global x-axis in a bearing at A = (0, 0.1, 0.12);
# a connecting rod runs from the crank pin B to a slider C that moves on
# the x-axis.  The crank (0.08 m) points along +z at t = 0, so B = (0, 0.1,
# 0.2) and, with the rod 0.3 m long, C = (0.2, 0, 0).  Joints: a revolute
# pair ground-crank about x at A, a spherical joint at B, a universal joint
# at C (its slider-fixed axis e_x, its rod-fixed axis perpendicular to the
# rod and to e_x) and a prismatic pair slider-ground along x.  Three rigid
# bodies (18 coordinates) minus 5 + 3 + 4 + 5 = 17 conditions: one degree of
# freedom, the crank angle.  Data of the IFToMM library of computational
# benchmark problems ("Spatial rigid slider-crank mechanism"):
#
#   crank  m = 0.12 kg, J = 1e-4 kg m^2 about the axes across it, 1e-5 about its own axis
#   rod    m = 0.5 kg,  J = 4e-3 across, 4e-4 about its own axis
#   slider m = 2 kg,    J = 1e-4 (isotropic; it does not turn)
#
# each centre of mass at the body's middle, gravity 9.81 m/s^2 in -z, the
# crank turning at omega = 6 rad/s about +x at t = 0, everything else
# moving as the joints allow; T = 5 s.
#
# Every body is the director-based rigid body of forms/rigid_body.py: its
# centre of mass and its principal axes d1, d2, d3 are the coordinates, so
# every joint below is quadratic in them and holds to round-off (the index-2
# midpoint rule is exact for quadratic constraints).  A joint axis must be a
# body-fixed direction, so each body's directors are chosen as the joint
# axes it carries (any pair of axes across a crank or rod is principal: the
# two moments across are equal).
#
# What to look at: `slider_x` (the slider's position x_C along the x-axis;
# the published reference curve), `crank_tip_y, crank_tip_z` (the crank pin
# B), the energy balance H_{n+1} - H_n = h y.u (rodfem's H is the kinetic
# energy; gravity is the input port, so H - supplied is the conserved total
# energy minus V(0) = 0.678852 J: H - supplied + V(0) = 0.76643568 J), and
# `constraint_residual`, the largest |g(q)| of the four joints.  The
# reactions are the columns `bearing_A.lambda1..5`, `ball_B.lambda1..3`,
# `cardan_C.lambda1..4`, `guide.lambda1..5`.
#
# The exact motion comes from energy conservation of the one-degree-of-
# freedom mechanism, t(theta) = int sqrt(M(theta) / (2 (H - V(theta))))
# dtheta (demos/_slider_crank_reference.py): about 0.5789 s per crank
# revolution, x_C(5) = 0.2407196 m.  The midpoint rule is second order: with
# dt = 1e-3 the slider position stays within 6.3e-5 m of it over [0, 5] s
# (9.3e-3 m with dt = 0.01, where rodfem reproduces the port-Hamiltonian
# midpoint results of Latussek, Kinon and Betsch to the 9 digits they
# publish; see benchmarks/bench_slider_crank.md).
#
# `n_elements` is one of the parameters every scene has: rigid bodies have
# no mesh to refine, so it is ignored here.
#
# Run it:  rodfem run slider-crank-3d --out results/slider-crank-3d
#          rodfem run slider-crank-3d --set dt=0.0005

import sys

import numpy as np

from rodfem import Load
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common
from rodfem.core.joints import ground
from rodfem.core.system import System
from rodfem.forms import joints
from rodfem.forms.rigid_body import RigidBody
from rodfem.io.sections import Section

try:
    from rodfem.demos import _slider_crank_reference as exact
except ImportError:   # run as a script
    import _slider_crank_reference as exact

parameters = common(n_elements=1, dt=1e-3, t_end=5.0) + [
    Parameter("omega0", 6.0, "rad/s", "initial crank rate about +x", low=0, low_open=True),
    Parameter("g", 9.81, "m/s^2", "gravity, acting in -z", low=0),
]

A = np.array([0.0, 0.1, 0.12])          # the crank bearing (revolute about x)
L_CRANK, L_ROD = 0.08, 0.3
E_X = np.array([1.0, 0.0, 0.0])
# Newton stops at |F| <= 1e-12 (the engine's default 1e-10 is coarse for rows that carry inertias of
# 1e-5 kg m^2: it left director orthonormality errors of 3e-12 and balance errors of 4e-13 J; 1e-12
# costs 6 % more iterations and brings both to round-off).
NEWTON = {"snes_atol": 1e-12}


def geometry():
    """The configuration at t = 0: the crank pin B, the slider C, and each body's directors [d1 d2 d3]."""
    B = A + L_CRANK * np.array([0.0, 0.0, 1.0])
    C = np.array([np.sqrt(L_ROD**2 - B[1]**2 - B[2]**2), 0.0, 0.0])
    # crank: d1 = e_x (the bearing's axis), d2 along the crank from A to B
    crank = _frame(E_X, (B - A) / L_CRANK)
    # rod: d1 along the rod from B to C, d2 = e_x x d1 / |.| (the universal joint's rod-fixed axis)
    u = (C - B) / L_ROD
    rod = _frame(u, np.cross(E_X, u) / np.linalg.norm(np.cross(E_X, u)))
    return B, C, crank, rod, np.eye(3)


def _frame(d1, d2):
    return np.column_stack([d1, d2, np.cross(d1, d2)])


def initial_velocities(omega0):
    """Velocities consistent with the joints when the crank turns at omega0 about +x:
    v_B = omega x (B - A); the rod keeps its length, (C - B).(v_C - v_B) = 0 with v_C = v e_x;
    the rod turns with omega_perp = r x (v_C - v_B) / |r|^2 (r = C - B) plus a spin s about its
    axis u that keeps the universal joint's rod axis n ~ e_x x u perpendicular to e_x:
    d/dt (n . e_x) = omega . (n x e_x) = 0."""
    B, C, _crank, rod, _ = geometry()
    w_crank = np.array([omega0, 0.0, 0.0])
    v_B = np.cross(w_crank, B - A)
    r = C - B
    v_C = (r @ v_B) / (r @ E_X) * E_X
    w_perp = np.cross(r, v_C - v_B) / (r @ r)
    u, n = rod[:, 0], rod[:, 1]
    spin = -(w_perp @ np.cross(n, E_X)) / (u @ np.cross(n, E_X))
    return dict(crank=(np.cross(w_crank, 0.5 * (B - A)), w_crank), rod=(0.5 * (v_B + v_C), w_perp + spin * u),
                slider=(v_C, np.zeros(3)))


def build(p, comm):
    B, C, R_crank, R_rod, R_slider = geometry()
    v = initial_velocities(p["omega0"])
    mechanism = System(integrator=p["integrator"], comm=comm, newton_options=NEWTON)

    # ## The bodies: centre of mass, principal axes, and weight as a load on the velocity
    # (`link`: the output draws the crank and the rod as 1 cm bars between their joint points,
    # not as the boxes of their inertia; the slider stays a block)
    half_crank, half_rod = 0.5 * L_CRANK, 0.5 * L_ROD

    def add(name, m, J, centre, R, link=None):
        gravity = Load("v", [0.0, 0.0, -m * p["g"]], "domain", f"gravity {name}")
        x0 = RigidBody.initial(centre, R, *v[name])
        model = RigidBody(m, J)
        if link is not None:
            model.link, model.section = link, Section.round(0.005)
        return mechanism.add(name, model, loads=[gravity], initial=x0)
    crank = add("crank", 0.12, (1e-4, 1e-5, 1e-4), 0.5 * (A + B), R_crank, ((0, -half_crank, 0), (0, half_crank, 0)))
    rod = add("rod", 0.5, (4e-4, 4e-3, 4e-3), 0.5 * (B + C), R_rod, ((-half_rod, 0, 0), (half_rod, 0, 0)))
    slider = add("slider", 2.0, (1e-4, 1e-4, 1e-4), C, R_slider)

    # ## The joints: points in each body's frame (offsets along its directors)
    mechanism.join(joints.revolute(0), ground(A), crank.point((0.0, -half_crank, 0.0)), name="bearing_A")
    mechanism.join(joints.spherical, crank.point((0.0, half_crank, 0.0)), rod.point((-half_rod, 0.0, 0.0)),
                   name="ball_B")
    mechanism.join(joints.universal(axis_a=1, axis_b=0), rod.point((half_rod, 0.0, 0.0)), slider.point(),
                   name="cardan_C")     # the rod's d2 stays perpendicular to the slider's d1 = e_x
    mechanism.join(joints.prismatic(0), ground(), slider.point(), name="guide")   # along the ground's d1 = e_x

    # ## What to record: the slider and the crank pin
    mechanism.marker("slider", slider.point())
    mechanism.marker("crank_tip", crank.point((0.0, half_crank, 0.0)))
    return mechanism


def crank_angle(tip_y, tip_z):
    """The crank angle theta about +x from +z, from the crank pin B (unwrapped over a history)."""
    return np.unwrap(np.arctan2(-(np.asarray(tip_y) - A[1]), np.asarray(tip_z) - A[2]))


def reference(p):
    """The exact slider position at t_end (demos/_slider_crank_reference.py), scaled by the stroke."""
    data = dict(exact.DATA, omega0=p["omega0"], g=p["g"])
    ref = exact.Reference(data)
    stroke = np.ptp(exact.kinematics(np.linspace(0, 2 * np.pi, 721), data)["x"])
    return {"slider_x": float(ref.state(p["t_end"])["x_C"]), "scale": float(stroke)}


scene = Scene("slider-crank-3d", "IFToMM spatial rigid slider-crank: crank, rod and slider joined by revolute, "
              "spherical, universal and prismatic pairs, under gravity", parameters, build, reference=reference,
              reference_is_static=False)   # the exact motion at t_end, not an equilibrium

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
