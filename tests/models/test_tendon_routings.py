"""Tendons on converging and helical routings against Rucker & Webster's model, solved here from scratch.

The FE tendon (forms/actuators.py) acts through the variation of tau times its
length.  The oracle below knows nothing of that: it is the coupled
rod/tendon model of Rucker & Webster (IEEE T-RO 27(6) 2011, section III) in
its distributed-load form.  A frictionless tendon of tension tau along
p = r + R y(s) (y = (0, y_a, y_b) in the section frame) is in equilibrium
under the wall forces of the rod, so it loads the rod with

    f_t = tau t'  per unit s,  l_t = (R y) x f_t       (t = p'/|p'|, world frame)

and, where it is fixed (s_end), with the point force -tau t and moment
(R y) x (-tau t).  With p' = R e, e = v + u x y + y' (v = R^T r', u the
curvature), t' = -hat(p')^2 p''/|p'|^3 brings in v' and u', so the rod's
equilibrium n' + f = 0, m' + r' x n + l = 0 with n = R K_se (v - e1),
m = R K_bt u becomes the linear system of their section III for (v', u'):

    [K_se + A   G      ] [v']   [-u x N - a - R^T f_ext        ]
    [B          K_bt + H] [u'] = [-u x M - v x N - b            ]

    A_i = -tau hat(e)^2/|e|^3,  G_i = -A_i hat(y),  a_i = A_i (u x e + u x y' + y''),
    B_i = hat(y) A_i,  H_i = hat(y) G_i,  b_i = hat(y) a_i.

It is integrated from the clamp (DOP853, rtol 1e-12) with the unknown
v(0), u(0) (shooting, Newton on N = M = 0 at the free tip); where a tendon is
fixed, N and M jump by its pull (N += tau t, M += tau y x t in the section
frame: beyond it the rod does not carry it).  The routings'
y, y', y'' are written out here, not taken from the Routing objects.  Checks
of the oracle itself: a straight tendon gives the circular arc (and a
straight rest beyond the tendon's end) to 1e-10.

The FE equilibria come from rodfem's statics (analysis/statics.py: no
load-step error, only the spatial one), at two meshes: the error falls at
the element's order (planar beam k = 2: 4; k = 1: 2; 3D rod P2/DG1: 4).
Shear and axial stiffnesses are moderate (EA = GA = 10^3 EI/L^2) and the
routings steep (|y'| up to 0.1), so that what the slope y' of a routing does
to the tip (about 1e-3 L through the tendon's tilt: shear force tau y' and
the factor 1/|e| of the moment) is far above the discretization error.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rodfem import Load, Problem, Support
from rodfem.analysis.statics import Statics
from rodfem.demos._rod3d import NEWTON, straight
from rodfem.forms import actuators as act
from rodfem.forms.cosserat_rod import CosseratRod
from rodfem.forms.planar_beam import PlanarBeam, quadratic

E1 = np.array([1.0, 0.0, 0.0])
L = 1.0


# -- the oracle: Rucker & Webster's coupled model, distributed loads, shooting ------------------------

def hat(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rucker_webster(K_se, K_bt, tendons, f_ext=(0.0, 0.0, 0.0), length=L, rtol=1e-12):
    """Static shape of a rod clamped at s = 0 (R(0) = I), free at s = length, under tendons
    [(tau, path, s_end)] (path(s) -> (y, y', y''), 3-vectors in the section frame with first component 0)
    and a force per length f_ext (world frame).  Returns (r(L), R(L))."""
    ks, kb = np.asarray(K_se, float), np.asarray(K_bt, float)
    f = np.asarray(f_ext, float)
    stops = sorted({float(e) for _, _, e in tendons} | {float(length)})

    def rhs(s, z, active):
        R, v, u = z[3:12].reshape(3, 3), z[12:15], z[15:18]
        N, M = ks * (v - E1), kb * u
        A, G, B, H = (np.zeros((3, 3)) for _ in range(4))
        a, b = np.zeros(3), np.zeros(3)
        for tau, path, _ in active:
            y, dy, ddy = path(s)
            e = v + np.cross(u, y) + dy                     # p' in the section frame
            Ai = -tau * hat(e) @ hat(e) / np.linalg.norm(e) ** 3
            ai = Ai @ (np.cross(u, e) + np.cross(u, dy) + ddy)
            Gi = -Ai @ hat(y)
            A, G, B, H = A + Ai, G + Gi, B + hat(y) @ Ai, H + hat(y) @ Gi
            a, b = a + ai, b + hat(y) @ ai
        lhs = np.block([[np.diag(ks) + A, G], [B, np.diag(kb) + H]])
        dvu = np.linalg.solve(lhs, np.concatenate([-np.cross(u, N) - a - R.T @ f,
                                                   -np.cross(u, M) - np.cross(v, N) - b]))
        return np.concatenate([R @ v, (R @ hat(u)).ravel(), dvu])

    def wild(s, z, active):          # |u| = 100/L: a trial start far from any shape sought here
        return 100.0 / length - np.linalg.norm(z[15:18])
    wild.terminal = True

    def integrate(x0):
        z = np.concatenate([np.zeros(3), np.eye(3).ravel(), x0])
        if wild(0.0, z, ()) < 0:
            return None
        s0 = 0.0
        for s1 in stops:
            active = [t for t in tendons if t[2] > s0 + 1e-12]
            sol = solve_ivp(rhs, (s0, s1), z, method="DOP853", rtol=rtol, atol=1e-2 * rtol, args=(active,),
                            events=wild)
            if sol.status == 1:
                return None
            z = sol.y[:, -1]
            v, u = z[12:15], z[15:18]
            for tau, path, s_end in tendons:        # fixed here: beyond s1 the rod carries no pull of it
                if abs(s_end - s1) < 1e-12:
                    y, dy, _ = path(s1)
                    e = v + np.cross(u, y) + dy
                    t = e / np.linalg.norm(e)
                    v, u = v + tau * t / ks, u + tau * np.cross(y, t) / kb
            z = np.concatenate([z[:12], v, u])
            s0 = s1
        return z

    def free_tip(x0):
        z = integrate(x0)
        if z is None:
            return np.full(6, 1e3)
        return np.concatenate([ks * (z[12:15] - E1) / ks.max(), kb * z[15:18] / kb.max()])

    # start: the tendons' pull at s = 0 and the weight of the straight rod; Newton, halving bad steps
    N0, M0 = length * f, np.cross(length ** 2 / 2 * E1, f)
    for tau, path, _ in tendons:
        y, dy, _ = path(0.0)
        t = (E1 + dy) / np.linalg.norm(E1 + dy)
        N0, M0 = N0 - tau * t, M0 - tau * np.cross(y, t)
    x = np.concatenate([E1 + N0 / ks, M0 / kb])
    F = free_tip(x)
    for _ in range(40):
        if np.max(np.abs(F)) < 1e-12:
            break
        J = np.column_stack([(free_tip(x + 1e-7 * dx) - F) / 1e-7 for dx in np.eye(6)])
        step, lam = np.linalg.solve(J, -F), 1.0
        while True:
            F_new = free_tip(x + lam * step)
            if np.linalg.norm(F_new) < np.linalg.norm(F) or lam < 1e-3:
                break
            lam *= 0.5
        x, F = x + lam * step, F_new
    assert np.max(np.abs(F)) < 1e-12, F
    z = integrate(x)
    return z[:3], z[3:12].reshape(3, 3)


# the routings, written out: y, y', y'' in the section frame (0, y_a, y_b)

def straight_path(ya, yb=0.0):
    return lambda s: (np.array([0.0, ya, yb]), np.zeros(3), np.zeros(3))


def converging_path(ya, yb, length):
    y0 = np.array([0.0, ya, yb])
    return lambda s: ((1.0 - s / length) * y0, -y0 / length, np.zeros(3))


def helical_path(radius, rate, phase):
    def path(s):
        c, sn = np.cos(rate * s + phase), np.sin(rate * s + phase)
        return (radius * np.array([0.0, c, sn]), radius * rate * np.array([0.0, -sn, c]),
                -radius * rate ** 2 * np.array([0.0, c, sn]))
    return path


def test_oracle_gives_the_arc_of_a_straight_tendon():
    """A straight tendon at offset d: the arc kappa = tau d/EI, Gamma_1 = -tau/EA (the pull at the tip is
    the whole load); fixed at s = L/2, the arc over [0, L/2] and a straight, unstrained rest."""
    EA, EI, d, tau = 1e3, 1.0, 0.05, 10.0
    kappa, eps = tau * d / EI, -tau / EA
    rho = (1 + eps) / kappa

    def arc(s):
        return np.array([rho * np.sin(kappa * s), rho * (1 - np.cos(kappa * s)), 0.0]), kappa * s
    for end in (L, L / 2):
        r, R = rucker_webster((EA, EA, EA), (EI, EI, EI), [(tau, straight_path(d), end)])
        r_end, phi = arc(end)
        exact = r_end + (L - end) * np.array([np.cos(phi), np.sin(phi), 0.0])
        assert np.linalg.norm(r - exact) <= 1e-10 * L, (end, r - exact)
        assert abs(np.arctan2(R[1, 0], R[0, 0]) - phi) <= 1e-10 and abs(R[2, 2] - 1) <= 1e-12


# -- planar beam ---------------------------------------------------------------------------------------

EA2, GA2, EI2 = 1e3, 1e3, 1.0

# id: (tension, Routing (FE), path (oracle), tendon end (None: tip), force per length (x, y))
PLANAR = {
    "taper-to-axis": (10.0, act.converging(0.1, L), converging_path(0.1, 0.0, L), None, (0.0, 0.0)),
    "taper-under-weight": (12.0, act.converging(-0.08, 2 * L), converging_path(-0.08, 0.0, 2 * L), None, (0.0, -3.0)),
    "taper-ending-mid-span": (10.0, act.converging(0.1, L), converging_path(0.1, 0.0, L), L / 2, (0.0, 2.0)),
}


def planar_statics(case, n, degree):
    """Tip (x, y) and angle of the FE statics of the planar beam."""
    tau, routing, _, end, f = PLANAR[case]
    beam = PlanarBeam(0.0, 0.0, quadratic(EA2, GA2, EI2), degree=degree)
    loads = [act.Tendon(tau, routing, radius=0.2, end=end, name="t")]
    if any(f):
        loads.append(Load("v", list(f), "domain", "weight"))
    P = Problem(beam, L, n, loads=loads, supports=[Support("left", "clamped")],
                initial={"r": lambda x: np.vstack([x[0], 0 * x[0]])})
    Statics(P).solve(0.0, 4)
    s, r = P.space.nodal(P.x0, "r")
    _, phi = P.space.nodal(P.x0, "phi")
    return r[np.argmax(s)], float(phi[np.argmax(s)])


def planar_oracle(case):
    tau, _, path, end, f = PLANAR[case]
    r, R = rucker_webster((EA2, GA2, GA2), (EI2, EI2, EI2), [(tau, path, end or L)], (*f, 0.0))
    assert abs(r[2]) <= 1e-14 and abs(R[2, 2] - 1) <= 1e-14        # it stays in its plane
    return r[:2], np.arctan2(R[1, 0], R[0, 0])


@pytest.mark.parametrize("case", list(PLANAR))
def test_planar_tendon_on_a_converging_routing_matches_rucker_webster(case):
    """Planar beam (k = 2), tendon offset tapering linearly (to the axis at L, or to half at L with a weight,
    or fixed at L/2): tip position and angle against the oracle; the error falls at order 4 from 8 to 16
    elements."""
    r_ref, phi_ref = planar_oracle(case)
    err = []
    for n in (8, 16):
        r, phi = planar_statics(case, n, degree=2)
        err.append((np.linalg.norm(r - r_ref) / L, abs(phi - phi_ref)))
    print(case, "tip", r_ref, "phi", phi_ref, "errors (n = 8, 16):", err)
    (e8, a8), (e16, a16) = err
    assert e16 <= 2e-6 and a16 <= 2e-6, err        # measured <= 6.2e-7 L, 6.1e-7 (the slope y' does ~1e-3)
    assert e8 / e16 >= 2 ** 3.5 and a8 / a16 >= 2 ** 3.5, err
    assert abs(phi_ref) > 0.3                      # a large deflection


def test_planar_default_element_converges_to_rucker_webster():
    """The paper's element (k = 1) on the tapering routing: second order, and the Richardson extrapolation
    of 16 and 32 elements is the oracle's tip."""
    r_ref, phi_ref = planar_oracle("taper-to-axis")
    (r16, p16), (r32, p32) = (planar_statics("taper-to-axis", n, degree=1) for n in (16, 32))
    e16, e32 = np.linalg.norm(r16 - r_ref), np.linalg.norm(r32 - r_ref)
    rich = np.linalg.norm((4 * r32 - r16) / 3 - r_ref)
    print("k = 1: errors", e16, e32, "order", np.log2(e16 / e32), "Richardson", rich, abs((4 * p32 - p16) / 3 - phi_ref))
    assert 1.9 <= np.log2(e16 / e32) <= 2.1, (e16, e32)
    assert rich <= 1e-6 * L and abs((4 * p32 - p16) / 3 - phi_ref) <= 1e-6, rich


# -- 3D rod ---------------------------------------------------------------------------------------------

K_SE, K_BT = (1e3, 1e3, 1e3), (0.8, 1.0, 1.0)
A_CONV, A_TAPER = act.on_circle(0.1, 0.5), act.on_circle(0.08, 2.5)

# id: (tension, Routing (FE), path (oracle), tendon end (None: tip), force per length (world)); the two
# converging and the two helical cases share their compiled forms (a weight, maybe zero; an end or none)
ROD = {
    "converging-to-axis": (8.0, act.converging(A_CONV, L), converging_path(*A_CONV, L), None, (0.0, 0.0, 0.0)),
    "converging-to-half-under-weight": (10.0, act.converging(A_TAPER, 2 * L), converging_path(*A_TAPER, 2 * L), None,
                                        (0.0, 0.0, -3.0)),
    "helical-1.5-turns-under-weight": (10.0, act.helical(0.06, 3 * np.pi, 0.3), helical_path(0.06, 3 * np.pi, 0.3),
                                       L, (0.0, 0.0, -3.0)),
    "helical-ending-at-0.75-under-weight": (6.0, act.helical(0.08, 4.0), helical_path(0.08, 4.0, 0.0), 0.75,
                                            (0.0, 2.0, 0.0)),
}


def rod_statics(case, n):
    """Tip position and directors [d1 d2 d3] of the FE statics of the 3D rod (d1 = e_x at rest)."""
    tau, routing, _, end, f = ROD[case]
    rod = CosseratRod(0.0, (0.0, 0.0, 0.0), [1 / k for k in K_SE], [1 / k for k in K_BT])
    loads = [act.Tendon(tau, routing, radius=0.2, end=end, name="t"), Load("v", list(f), "domain", "weight")]
    P = Problem(rod, L, n, loads=loads, supports=[Support("left", "clamped")], initial=straight((0, 0, 0), np.eye(3)),
                newton_options=NEWTON)
    Statics(P).solve(0.0, 4)
    s, r = P.space.nodal(P.x0, "r")
    tip = np.argmax(s)
    return r[tip], np.column_stack([P.space.nodal(P.x0, f"d{i}")[1][tip] for i in (1, 2, 3)])


@pytest.mark.parametrize("case", list(ROD))
def test_rod_tendon_on_converging_and_helical_routings_matches_rucker_webster(case):
    """3D rod (P2/DG1), 8 and 16 elements: tip position and directors against the oracle, order 4."""
    tau, _, path, end, f = ROD[case]
    r_ref, R_ref = rucker_webster(K_SE, K_BT, [(tau, path, end or L)], f)
    err = []
    for n in (8, 16):
        r, R = rod_statics(case, n)
        err.append((np.linalg.norm(r - r_ref) / L, np.max(np.abs(R - R_ref))))
    print(case, "tip", r_ref, "errors (n = 8, 16):", err)
    (e8, d8), (e16, d16) = err
    assert e16 <= 1e-5 and d16 <= 5e-5, err       # measured <= 4.0e-6 L, 1.9e-5 (helical, 1.5 turns)
    assert e8 / e16 >= 2 ** 3.5 and d8 / d16 >= 2 ** 3.5, err
    assert min(abs(r_ref[1]), abs(r_ref[2])) > 1e-3 * L     # out of every coordinate plane: 3D
