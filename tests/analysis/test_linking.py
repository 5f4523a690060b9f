"""Twist, writhe and link of polygons (rodfem/analysis/linking.py) against analytic values: a planar curve has
no writhe; a helix of N turns at the angle alpha to its axis, entered and left along the axis, has the writhe
N (1 - cos alpha) (Fuller's formula: the kinks between the straight leads and the helix add nothing), its
principal normal the twist N cos alpha, so the link N; Fuller's integral of a smooth non-reversing curve
equals the Gauss integral of its far closure; a straight rod whose d2 turns by theta has Tw = theta/2 pi;
twisting a ribbon's far end by a full turn after a crossing jumps Lk by 2 (the sign of a crossing)."""
import numpy as np
import pytest

from rodfem.analysis.linking import closure, fuller, link, twist, writhe


def helix(N, alpha, R=0.1, per_turn=200, lead=0.3):
    """Straight lead along x from the origin, a helix of N turns (radius R, tangent at alpha to x) whose axis
    is the line y = R, then a straight lead back on the x axis: (points, principal normals)."""
    phi = np.linspace(0.0, 2 * np.pi * N, per_turn * N + 1)
    x = lead + R / np.tan(alpha) * phi
    pts = np.c_[x, R - R * np.cos(phi), R * np.sin(phi)]
    normal = np.c_[0 * phi, np.cos(phi), -np.sin(phi)]
    m = 20
    before = np.c_[np.linspace(0.0, lead, m)[:-1], np.zeros((m - 1, 2))]
    after = np.c_[x[-1] + np.linspace(0.0, lead, m)[1:], np.zeros((m - 1, 2))]
    return (np.vstack([before, pts, after]),
            np.vstack([np.tile(normal[0], (m - 1, 1)), normal, np.tile(normal[-1], (m - 1, 1))]))


def test_planar_curves_have_no_writhe():
    th = np.linspace(0, 2 * np.pi, 97, endpoint=False)
    assert writhe(np.c_[np.cos(th), np.sin(th), 0 * th]) == 0.0
    assert writhe(np.c_[np.cos(th), np.sin(2 * th) + 0.3 * np.cos(3 * th), 0 * th]) == pytest.approx(0.0, abs=1e-12)
    # any rotation of a non-planar curve keeps its writhe; a mirror image flips its sign
    P = closure(helix(2, 0.6, per_turn=40)[0])
    Q = np.linalg.qr(np.random.default_rng(1).standard_normal((3, 3)))[0]
    Q *= np.sign(np.linalg.det(Q))
    assert writhe(P @ Q.T) == pytest.approx(writhe(P), abs=1e-10)
    assert writhe(P * [1, 1, -1]) == pytest.approx(-writhe(P), abs=1e-10)


@pytest.mark.parametrize("N, alpha", [(3, 0.5), (2, 1.0)])
def test_helix_writhe_twist_and_link(N, alpha):
    """Wr -> N (1 - cos alpha) as the segments shrink; Tw of the principal normal
    -> N cos alpha; Lk = N (sign: this helix is left-handed) to the closure's far error."""
    exact = -N * (1 - np.cos(alpha))
    errors = []
    for per_turn in (50, 100, 200):
        P, U = helix(N, alpha, per_turn=per_turn)
        errors.append(abs(writhe(closure(P)) - exact))
    assert errors[0] > errors[1] > errors[2]
    assert errors[-1] < 4e-3 * abs(exact)
    P, U = helix(N, alpha, per_turn=200)
    ribbon = 0.5 * (U[1:] + U[:-1])
    assert twist(P, ribbon) == pytest.approx(-N * np.cos(alpha), abs=4e-3 * N)
    Tw, Wr, Lk = link(P, U)
    assert Lk == pytest.approx(-N, abs=1e-6)


def test_fuller_equals_the_gauss_integral_of_the_far_closure():
    """A smooth curve whose tangent never turns back, t = (cos a, sin a cos phi, sin a sin phi) with
    a = a0 sin^2(pi s) and phi = 2 pi n s (ends along x); its end is moved onto the x axis by a straight
    lead (no writhe by Fuller: t along x).  Fuller's integral = the polygon's Gauss integral, closed far."""
    n = 600
    s = np.linspace(0.0, 1.0, n + 1)
    a, phi = 1.2 * np.sin(np.pi * s) ** 2, 2 * np.pi * 3 * s
    t = np.c_[np.cos(a), np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi)]
    ds = 1.0 / n
    x = np.vstack([np.zeros(3), np.cumsum(0.5 * (t[1:] + t[:-1]) * ds, axis=0)])
    # back onto the axis: along x (no writhe), then across in the plane x = const (a planar hook)
    end = x[-1]
    hook = np.array([end + [0.2, 0, 0], end + [0.2, 0, 0] - [0, end[1], end[2]]]) + [[0, 0, 0], [0.0, 0, 0]]
    closed = np.vstack([x, hook, hook[-1] + [0.2, 0, 0]])
    wr_fuller = fuller(t, ds)
    wr_gauss = writhe(closure(closed))
    assert abs(wr_fuller) > 0.3
    assert wr_gauss == pytest.approx(wr_fuller, abs=2e-4)


def test_straight_twisted_rod_and_a_crossing():
    """Tw of a straight rod whose d2 turns by theta is theta / 2 pi (Wr = 0); a loop made to cross itself
    changes Lk by 2 while Tw + Wr of the uncrossed one holds."""
    s = np.linspace(0, 1, 41)
    for turns in (0.3, 1.7, -2.2):
        th = 2 * np.pi * turns * s
        Tw, Wr, Lk = link(np.c_[s, 0 * s, 0 * s], np.c_[0 * s, np.cos(th), np.sin(th)])
        assert Tw == pytest.approx(turns, abs=1e-12) and Wr == pytest.approx(0.0, abs=1e-12)

    u = np.linspace(0, 1, 401)
    f = 2 * u - 1 + 0.6 * np.sin(2 * np.pi * u)          # x(u) = x(1 - u) where f = 0: the crossing
    k = int(np.argmax((f[1:200] > 0) != (f[:199] > 0)))
    u1 = u[k] - f[k] * (u[k + 1] - u[k]) / (f[k + 1] - f[k])

    def loop(h):
        """A loop in the xy plane, x = u + 0.3 sin 2 pi u, y = 0.2 (1 - cos 2 pi u) (ends on the x axis along
        it), lifted by h where it passes over itself (h < 0: under)."""
        x = u + 0.3 * np.sin(2 * np.pi * u)
        y = 0.2 * (1 - np.cos(2 * np.pi * u))
        z = h * np.exp(-((u - u1) / 0.03) ** 2)
        d = np.c_[0 * u, 0 * u, 1 + 0 * u]
        return np.c_[x, y, z], d
    over, under = link(*loop(0.05)), link(*loop(-0.05))
    assert abs(over[2] - under[2]) == pytest.approx(2.0, abs=1e-6)
