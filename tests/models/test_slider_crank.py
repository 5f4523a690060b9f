"""slider-crank-3d: the IFToMM spatial rigid slider-crank against its exact motion, and the universal joint.

Measured on [0, 1] s at dt = 2e-3 (serial; the bounds below are stated
multiples of these): per-step energy balance 1.7e-14 of max H, drift of the
conserved total energy 5.5e-14 J, joint residuals |g| 3.7e-16, director
orthonormality |R^T R - I| 2.1e-14; slider position max_t |x_C - exact|
4.70e-5 m (crank angle 1.6e-3 rad), falling with order 2.00 between
dt = 4e-3, 2e-3, 1e-3; serial and mpirun -n 2 agree to 6e-13.
"""
import csv
import functools
import os

import numpy as np
import pytest
from mpi4py import MPI

from rodfem import run
from rodfem.core.joints import Frame, Joint, Point, ground
from rodfem.demos import _slider_crank_reference as exact
from rodfem.demos import slider_crank_3d
from rodfem.errors import ConstraintError
from rodfem.forms import joints

T_END = 1.0       # about 1.7 crank revolutions
DT = 2e-3


@functools.lru_cache(maxsize=None)
def simulate(dt, t_end=T_END):
    """(history columns, largest director orthonormality error, dofs) of a serial run."""
    scene = slider_crank_3d.scene
    p = scene.values({"dt": dt, "t_end": t_end})
    system = scene.build(p, MPI.COMM_SELF)
    worst = [0.0]

    class Orthonormality:
        def record(self, row, system):
            for ref in system.bodies.values():
                b = ref.body
                R = np.column_stack([b.space.nodal(b.x1, d)[1][0] for d in ("d1", "d2", "d3")])
                worst[0] = max(worst[0], float(np.max(np.abs(R.T @ R - np.eye(3)))))
    res = run(system, dt, t_end, writer=Orthonormality())
    cols = {k: res.column(k) for k in res.rows[0]}
    return cols, worst[0], system.dofs


@functools.lru_cache(maxsize=None)
def reference():
    return exact.Reference()


# -- the exact motion and the initial state ---------------------------------------------------

def test_reference_reproduces_the_benchmark_values():
    ref = reference()
    H, T0, V0 = exact.energy()
    assert abs(H - 0.76643568) < 1e-12 and abs(T0 - 0.08758368) < 1e-12 and abs(V0 - 0.678852) < 1e-12
    assert abs(ref.period - 0.578897) < 5e-7
    x = ref.state(np.arange(1.0, 6.0))["x_C"]
    assert np.allclose(x, [0.2117217, 0.2890852, 0.2284848, 0.1882305, 0.2407196], atol=6e-8, rtol=0)
    theta = ref.angle(np.array([0.3, 2.7, 4.9]))                 # Fourier series vs composite Gauss
    assert np.max(np.abs(ref.time(theta) - exact.composite_gauss(theta))) < 1e-13
    assert np.allclose(ref.time(theta), [0.3, 2.7, 4.9], atol=1e-14, rtol=0)


def test_initial_velocities_are_consistent():
    v = slider_crank_3d.initial_velocities(6.0)
    assert np.allclose(v["slider"][0], [0.24, 0, 0], atol=1e-14)
    assert np.allclose(v["rod"][0], [0.12, -0.24, 0], atol=1e-14)
    assert np.allclose(v["rod"][1], [1.92, -0.96, 0.48], atol=1e-13)   # includes 1.28 rad/s spin about the rod
    u = slider_crank_3d.geometry()[3][:, 0]
    assert abs(v["rod"][1] @ u - 1.28) < 1e-13
    ref = exact.initial_velocities()        # the reference's kinematics, derived independently
    assert np.allclose(v["rod"][1], ref["omega_rod"], atol=1e-13)
    assert np.allclose(v["slider"][0], ref["v_slider"], atol=1e-14)


# -- the simulation --------------------------------------------------------------------------

def test_structure_is_preserved():
    h, ortho, dofs = simulate(DT)
    assert dofs == 3 * (3 + 9 + 3 + 9 + 6) + (5 + 3 + 4 + 5)   # 3 bodies (x, d_i, v, w_i, lam) + 17 joint multipliers
    H = h["H"]
    assert abs(H[0] - 0.08758368) < 1e-14                         # kinetic energy at t = 0
    # per-step balance H_{n+1} - H_n = h y.u (gravity's work): measured 1.7e-14 of max H
    assert np.max(np.abs(h["balance_error"])) <= 1e-13 * np.max(np.abs(H))
    # the conserved total E = H - supplied + V(0) = 0.76643568 J
    E = H - h["supplied"] + exact.energy()[2]
    assert np.max(np.abs(E - 0.76643568)) < 5e-13                 # measured 5.5e-14 J
    # joints: position residuals at round-off (measured 3.7e-16), relative to the crank length 0.08 m
    assert np.max(h["constraint_residual"]) <= 1e-12 * 0.08
    assert ortho <= 2e-13                                         # |R^T R - I|, measured 2.1e-14
    # the slider stays on the x-axis, the crank pin on its circle about A in the plane x = 0
    assert np.max(np.abs(h["slider_y"])) < 1e-14 and np.max(np.abs(h["slider_z"])) < 1e-14
    A = slider_crank_3d.A
    r = np.hypot(h["crank_tip_y"] - A[1], h["crank_tip_z"] - A[2])
    assert np.max(np.abs(r - 0.08)) < 1e-14 and np.max(np.abs(h["crank_tip_x"])) < 1e-14


def test_agrees_with_the_exact_motion():
    h = simulate(DT)[0]
    st = reference().state(h["t"])
    err_x = np.max(np.abs(h["slider_x"] - st["x_C"]))
    theta = slider_crank_3d.crank_angle(h["crank_tip_y"], h["crank_tip_z"])
    err_theta = np.max(np.abs(theta - st["theta"]))
    assert err_x < 5e-5          # measured 4.70e-5 m (0.045 % of the 0.105 m stroke); over [0, 5] s: 2.5e-4 m
    assert err_theta < 1.7e-3    # measured 1.61e-3 rad after 10.9 rad of crank rotation


def test_time_order_two():
    dts = (4e-3, 2e-3, 1e-3)
    errors = []
    for dt in dts:
        h = simulate(dt)[0]
        errors.append(np.max(np.abs(h["slider_x"] - reference().state(h["t"])["x_C"])))
    orders = np.log(np.array(errors[:-1]) / errors[1:]) / np.log(2.0)
    assert np.all(np.abs(orders - 2.0) < 0.05), (errors, orders)   # measured 2.00, 2.00


# -- the universal joint --------------------------------------------------------------------

def _rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _bind(constraint, Ra, Rb, xa=(0.0, 0, 0), xb=(0.0, 0, 0)):
    """Bind `constraint` between two director frames (q = (x, d1, d2, d3) each); returns the Joint."""
    def frame(q):
        return Frame(x=q[:3], d=[q[3:6], q[6:9], q[9:12]])
    qa = np.concatenate([xa, *np.asarray(Ra).T])
    qb = np.concatenate([xb, *np.asarray(Rb).T])
    j = Joint(constraint, Point(None, "body"), Point(None, "body"), "u")
    j.bind(frame, frame, qa, qb, 1.0)
    return j, qa, qb


def test_universal_joint_is_quadratic_and_lets_the_right_motions_through():
    Ra = _rotation((1, 2, 3), 0.7)
    Rb = Ra @ np.column_stack([[0, 0, 1], [1, 0, 0], [0, 1, 0]])   # b's d1 = a's d3: perpendicular to a's d1
    j, qa, qb = _bind(joints.universal(axis_a=0, axis_b=0), Ra, Rb)
    assert j.size == 4
    n_a, n_b = Ra[:, 0], Rb[:, 0]

    def residual(Rb_new):
        return j.position_residual(np.concatenate([qa, np.zeros(3), *Rb_new.T]), 0.0)
    # b may turn about a's axis and about its own axis: both keep the axes perpendicular
    for axis in (n_a, n_b):
        assert np.max(np.abs(residual(_rotation(axis, 0.9) @ Rb))) < 1e-14
    # but not about the third direction n_a x n_b
    assert abs(residual(_rotation(np.cross(n_a, n_b), 0.3) @ Rb)[3]) > 0.1
    # an axis as components in the body's directors is the same joint
    j2 = _bind(joints.universal(axis_a=(1, 0, 0), axis_b=(1.0, 0, 0)), Ra, Rb)[0]
    assert np.allclose(j2.Q, j.Q) and np.allclose(j2.c, j.c)


def test_universal_joint_axes_must_start_perpendicular():
    with pytest.raises(ConstraintError, match="does not hold in the initial configuration"):
        _bind(joints.universal(axis_a=0, axis_b=0), np.eye(3), np.eye(3))


def test_universal_joint_on_a_ground_frame():
    """A ground frame's axes are its R: universal(axis_a=(0, 1, 0)) about the world y-axis."""
    j = Joint(joints.universal(axis_a=(0.0, 1.0, 0.0), axis_b=2), ground((0, 0, 0)), Point(None, "body"), "g")
    from rodfem.core.system import ground_frame
    g = ground_frame(ground((0, 0, 0)), 3)
    j.bind(lambda q: g, lambda q: Frame(x=q[:3], d=[q[3:6], q[6:9], q[9:12]]), np.zeros(0),
           np.concatenate([np.zeros(3), np.eye(3).ravel()]), 1.0)
    assert j.size == 4


# -- parallel ---------------------------------------------------------------------------------

def _history(path):
    with open(os.path.join(path, "history.csv")) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


@pytest.mark.mpi
def test_mpi_two_ranks_match_serial(rodfem, tmp_path):
    args = ["run", "slider-crank-3d", "--set", "t_end=0.2", "--set", "dt=0.002", "--quiet"]
    serial, par = tmp_path / "np1", tmp_path / "np2"
    assert rodfem(*args, "--out", str(serial)).returncode == 0
    p = rodfem(*args, "--out", str(par), np=2)
    assert p.returncode == 0, p.stderr[-2000:]
    a, b = _history(serial), _history(par)
    assert len(a["t"]) == len(b["t"]) == 101
    for col in a:
        scale = max(np.max(np.abs(a[col])), 1.0)
        assert np.max(np.abs(a[col] - b[col])) <= 1e-8 * scale, col   # measured 6e-13 (a reaction)
    assert np.array_equal(a["newton_its"], b["newton_its"])
