"""The exact motion of the IFToMM spatial rigid slider-crank, from energy conservation (numpy only).

The mechanism has one degree of freedom, the crank angle theta (about +x,
measured from +z; the crank turns the positive way, B moves to -y first).
Everything else follows from theta:

    B(theta) = A + l_c (0, -sin theta, cos theta),   C = (x_C, 0, 0),
    x_C(theta) = sqrt(l_r^2 - B_y^2 - B_z^2)          (the slider on the +x branch),

and every velocity is theta' times a function of theta: the crank turns
about A, the slider moves with x_C', the rod's centre with (B' + C')/2 and
the rod turns with omega = omega_perp + s u (u the rod axis):
omega_perp = r x r' / l_r^2 (r = C - B) is fixed by the ends, the spin s by
the universal joint at C (the rod-fixed axis b ~ e_x x u stays
perpendicular to the slider's axis e_x: omega . (u - u_x e_x) = 0, so
s = omega_perp_x u_x / (u_y^2 + u_z^2)).  Hence T = 1/2 M(theta) theta'^2 with

    M = J_A + m_s x_C'^2 + m_r |G_r'|^2 + J_r,perp |omega_perp|^2 + J_r,axial s^2,

J_A = J_c,perp + m_c (l_c/2)^2, and the potential V(theta) = g (m_c z_Gc + m_r z_Gr).
The energy H = T + V is conserved and V <= V(0) < H, so the crank never
stops and

    t(theta) = int_0^theta f,   f(phi) = sqrt(M(phi) / (2 (H - V(phi)))).

f is smooth and 2 pi-periodic: its Fourier series (sampled at N points)
converges geometrically and integrates exactly term by term, so t(theta) is
known to round-off; theta(t) follows by Newton's method on t(theta) = t
(dt/dtheta = f > 0).  `composite_gauss` is an independent check of t(theta).
"""
import numpy as np

# The benchmark's data (SI units)
DATA = dict(A=(0.0, 0.1, 0.12), l_crank=0.08, l_rod=0.3,
            m_crank=0.12, J_crank_perp=1e-4, J_crank_axial=1e-5,
            m_rod=0.5, J_rod_axial=4e-4, J_rod_perp=4e-3,
            m_slider=2.0, J_slider=1e-4,
            omega0=6.0, g=9.81)


def kinematics(theta, d=DATA):
    """Positions and their theta-derivatives (velocities per unit crank rate) at the crank angles theta."""
    th = np.asarray(theta, dtype=float)
    s, c = np.sin(th), np.cos(th)
    A, lc, lr = np.asarray(d["A"]), d["l_crank"], d["l_rod"]
    zero = np.zeros_like(th)
    B = np.stack([A[0] + zero, A[1] - lc * s, A[2] + lc * c], -1)
    dB = np.stack([zero, -lc * c, -lc * s], -1)
    x = np.sqrt(lr**2 - B[..., 1]**2 - B[..., 2]**2)
    dx = -(B[..., 1] * dB[..., 1] + B[..., 2] * dB[..., 2]) / x
    C = np.stack([x, zero, zero], -1)
    dC = np.stack([dx, zero, zero], -1)
    r, dr = C - B, dC - dB
    u = r / lr
    w_perp = np.cross(r, dr) / lr**2
    spin = w_perp[..., 0] * u[..., 0] / (u[..., 1]**2 + u[..., 2]**2)
    omega_rod = w_perp + spin[..., None] * u
    return dict(B=B, dB=dB, x=x, dx=dx, u=u, omega_perp=w_perp, spin=spin, omega_rod=omega_rod,
                crank_centre=0.5 * (A + B), rod_centre=0.5 * (B + C), d_rod_centre=0.5 * (dB + dC))


def mass(theta, d=DATA):
    """M(theta): T = 1/2 M theta'^2."""
    k = kinematics(theta, d)
    J_A = d["J_crank_perp"] + d["m_crank"] * (0.5 * d["l_crank"])**2
    return (J_A + d["m_slider"] * k["dx"]**2 + d["m_rod"] * np.sum(k["d_rod_centre"]**2, -1)
            + d["J_rod_perp"] * np.sum(k["omega_perp"]**2, -1) + d["J_rod_axial"] * k["spin"]**2)


def potential(theta, d=DATA):
    """V(theta) with the datum z = 0 (the slider stays at z = 0)."""
    k = kinematics(theta, d)
    return d["g"] * (d["m_crank"] * k["crank_centre"][..., 2] + d["m_rod"] * k["rod_centre"][..., 2])


def energy(d=DATA):
    """(H, T0, V0) of the initial state theta = 0, theta' = omega0."""
    T0 = 0.5 * float(mass(0.0, d)) * d["omega0"]**2
    V0 = float(potential(0.0, d))
    return T0 + V0, T0, V0


def integrand(theta, d=DATA):
    """f = dt/dtheta = sqrt(M / (2 (H - V)))."""
    H = energy(d)[0]
    return np.sqrt(mass(theta, d) / (2.0 * (H - potential(theta, d))))


class Reference:
    """t(theta) and theta(t) of the exact motion (Fourier series of f with n samples per revolution)."""

    def __init__(self, d=DATA, n=1024):
        self.d = d
        phi = 2 * np.pi * np.arange(n) / n
        F = np.fft.rfft(integrand(phi, d)) / n
        self.a0 = F[0].real                                   # f = a0 + sum_k a_k cos k phi + b_k sin k phi
        k = np.arange(1, len(F))
        self.k, self.a, self.b = k, 2 * F[1:].real, -2 * F[1:].imag
        if n % 2 == 0:   # the Nyquist term counts once
            self.a[-1] *= 0.5
            self.b[-1] = 0.0
        self.tail = np.max(np.abs(F[-8:]))                  # size of the last coefficients: the truncation error
        self.period = 2 * np.pi * self.a0                    # time per crank revolution

    def time(self, theta):
        """t(theta) = a0 theta + sum_k (a_k sin k theta - b_k (cos k theta - 1)) / k."""
        th = np.asarray(theta, dtype=float)
        kth = np.multiply.outer(th, self.k)
        return self.a0 * th + (np.sin(kth) @ (self.a / self.k)) - ((np.cos(kth) - 1.0) @ (self.b / self.k))

    def angle(self, t, tol=1e-15):
        """theta(t) by Newton's method on t(theta) = t."""
        t = np.asarray(t, dtype=float)
        th = t / self.a0
        for _ in range(50):
            step = (self.time(th) - t) / integrand(th, self.d)
            th = th - step
            if np.max(np.abs(step), initial=0.0) <= tol * max(1.0, np.max(np.abs(th), initial=0.0)):
                break
        return th

    def state(self, t):
        """dict of the exact motion at the times t: theta, omega (crank rate), x_C, v_C, ..."""
        th = self.angle(t)
        rate = 1.0 / integrand(th, self.d)
        k = kinematics(th, self.d)
        return dict(t=np.asarray(t, dtype=float), theta=th, omega=rate, x_C=k["x"], v_C=k["dx"] * rate,
                    B=k["B"], rod_centre=k["rod_centre"], omega_rod=k["omega_rod"] * rate[..., None])


def composite_gauss(theta, panels_per_revolution=400, points=8, d=DATA):
    """t(theta) by a composite Gauss-Legendre rule (an independent check of Reference.time)."""
    xg, wg = np.polynomial.legendre.leggauss(points)
    out = []
    for th in np.atleast_1d(theta):
        n = max(1, int(np.ceil(abs(th) / (2 * np.pi) * panels_per_revolution)))
        edges = np.linspace(0.0, th, n + 1)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
        nodes = mid[:, None] + half[:, None] * xg[None, :]
        out.append(np.sum(half[:, None] * wg[None, :] * integrand(nodes, d)))
    return np.array(out)


def initial_velocities(d=DATA):
    """The consistent initial velocities (theta = 0, theta' = omega0): slider, rod centre, rod, crank tip."""
    k = kinematics(0.0, d)
    w = d["omega0"]
    return dict(v_slider=np.array([k["dx"] * w, 0.0, 0.0]), v_rod=k["d_rod_centre"] * w,
                omega_rod=k["omega_rod"] * w, v_B=k["dB"] * w, omega_crank=np.array([w, 0.0, 0.0]))


if __name__ == "__main__":
    ref = Reference()
    H, T0, V0 = energy()
    print(f"H = {H:.10f}  T0 = {T0:.10f}  V0 = {V0:.10f}")
    print("initial velocities:", {k: np.round(v, 10).tolist() for k, v in initial_velocities().items()})
    print(f"time per crank revolution = {ref.period:.12f} s   (Fourier tail {ref.tail:.1e})")
    t = np.arange(0, 6)
    print("x_C(0..5) =", np.array2string(ref.state(t)["x_C"], precision=10))
    th = ref.angle(t)
    print("t(theta) Fourier - Gauss:", np.max(np.abs(ref.time(th) - composite_gauss(th))))
