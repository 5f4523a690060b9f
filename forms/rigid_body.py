"""Rigid bodies as port-Hamiltonian systems: a point mass, a planar body (x, phi) and the
director-based 3D body (x, d1, d2, d3).

Latussek, Kinon, Betsch (arXiv 2603.12841): a rigid body is described by its
centre of mass x and three directors d_i (the columns of its rotation), with
the CONSTANT mass matrix diag(m, E_1, E_2, E_3) of the velocities
(v, w_1, w_2, w_3), w_i = d_i', and the six orthonormality constraints
g_ij = 1/2 (d_i . d_j - delta_ij) = 0, on velocity level
G_d w = (d_i . w_j + d_j . w_i)_{i<=j} = 0 with multipliers lambda (the same
structure as the directors of the Cosserat rod, forms/cosserat_rod.py):

    d_t x = v,          m d_t v = f - (joint reactions)
    d_t d_i = w_i,      E_i d_t w_i = -(G_d^T lambda)_i - (joint reactions)
    0 = G_d(d) w
    H = 1/2 m |v|^2 + 1/2 sum_i E_i |w_i|^2     (quadratic: the midpoint rule is exact)

With d_i' = omega x d_i, sum_i E_i |w_i|^2 = omega . J omega for the inertia
tensor J = diag(J_1, J_2, J_3) about the principal axes d_i, through
E_k = (J_1 + J_2 + J_3)/2 - J_k (>= 0 by the triangle inequality of J).

The body lives on a mesh of one unit cell (rodfem/core/body.py): every field is
DG0, so int f dx = f and the forms below are the equations themselves.
Discretized like the rod: midpoint values, lambda at t_{n+1}; the
constraint rows hold exactly, so d_i . d_j = delta_ij for all time.
"""
import numpy as np
import ufl

from rodfem.core.joints import Frame
from rodfem.core.materials import ParameterSet
from rodfem.core.model import Field
from rodfem.forms.cosserat_rod import DIRECTORS, RATES, constraint_rate, director_frame, director_masses, orthonormality
from rodfem.forms.planar_beam import planar_directors, planar_frame


class PointMass:
    """A point mass m in `dim` dimensions: x, v;  H = 1/2 m |v|^2."""
    point = True
    position = "x"
    kinematics = {"x": "v"}
    labels = {"v": ("velocity of the point mass", ("x", "y", "z"))}
    units = {"x": "m", "v": "m/s"}   # SI
    supports = {}
    quadrature_degree = 0

    def __init__(self, mass, dim=3):
        if not (np.isfinite(mass) and mass > 0):
            raise ValueError(f"mass must be a positive number (got {mass!r})")
        self.dim = int(dim)
        self.parameters = ParameterSet(m=float(mass))
        self.fields = [Field("x", "DG", 0, (self.dim,)), Field("v", "DG", 0, (self.dim,))]

    def hamiltonian(self, x, dx, ds):
        m = self.parameters.on(dx.ufl_domain())["m"]
        return 0.5 * m * ufl.inner(x["v"], x["v"]) * dx

    def residual(self, step, test, dx, ds):
        m = self.parameters.on(dx.ufl_domain())["m"]
        return (ufl.inner(step.rate("x") - step.mid("v"), test["x"]) + m * ufl.inner(step.rate("v"), test["v"])) * dx

    def compatible_strains(self, x):
        return {}

    static_fields = ()   # statics: no rows to replace (rodfem/analysis/statics.py)

    def static_rows(self, x, ref, test, dx, ds):
        return None

    def momentum(self, x):
        m = self.parameters.on(ufl.domain.extract_unique_domain(x["v"]))["m"]
        p = m * x["v"]
        out = {f"p_{c}": p[i] for i, c in enumerate("xyz"[: self.dim])}
        if self.dim == 2:
            out["L_z"] = x["x"][0] * p[1] - x["x"][1] * p[0]
        else:
            L = ufl.cross(x["x"], p)
            out.update({f"L_{c}": L[i] for i, c in enumerate("xyz")})
        return out

    @staticmethod
    def frame(q, offset=()):
        if len(offset) and any(offset):
            raise ValueError("a point mass has no extent: a joint on it takes no offset")
        return Frame(x=np.asarray(q["x"], dtype=float))

    @staticmethod
    def initial(x, v=None):
        """Initial values: position x, velocity v."""
        x = np.asarray(x, dtype=float)
        v = np.zeros_like(x) if v is None else np.asarray(v, dtype=float)
        return {"x": _const(x), "v": _const(v)}


class PlanarRigidBody:
    """A planar rigid body: centre of mass x, angle phi, mass m, inertia J about the centre;
    H = 1/2 m |v|^2 + 1/2 J omega^2.  (A joint at an offset from x is not quadratic in phi:
    attach joints at the centre, or model the body with directors.)"""
    point = True
    position = "x"
    kinematics = {"x": "v", "phi": "omega"}
    labels = {"phi": ("angle of the body (rad)", ()), "v": ("velocity of the centre of mass", ("x", "y")),
              "omega": ("angular velocity d_t phi", ())}
    units = {"x": "m", "phi": "rad", "v": "m/s", "omega": "rad/s"}   # SI
    supports = {}
    quadrature_degree = 0

    def __init__(self, mass, inertia):
        for name, value in (("mass", mass), ("inertia", inertia)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number (got {value!r})")
        self.parameters = ParameterSet(m=float(mass), J=float(inertia))
        self.fields = [Field("x", "DG", 0, (2,)), Field("phi", "DG", 0), Field("v", "DG", 0, (2,)),
                       Field("omega", "DG", 0)]

    def hamiltonian(self, x, dx, ds):
        c = self.parameters.on(dx.ufl_domain())
        return (0.5 * c["m"] * ufl.inner(x["v"], x["v"]) + 0.5 * c["J"] * x["omega"] ** 2) * dx

    def residual(self, step, test, dx, ds):
        c = self.parameters.on(dx.ufl_domain())
        return (ufl.inner(step.rate("x") - step.mid("v"), test["x"]) + (step.rate("phi") - step.mid("omega")) * test["phi"]
                + c["m"] * ufl.inner(step.rate("v"), test["v"]) + c["J"] * step.rate("omega") * test["omega"]) * dx

    def compatible_strains(self, x):
        return {}

    static_fields = ()   # statics: no rows to replace (rodfem/analysis/statics.py)

    def static_rows(self, x, ref, test, dx, ds):
        return None

    def momentum(self, x):
        c = self.parameters.on(ufl.domain.extract_unique_domain(x["v"]))
        p = c["m"] * x["v"]
        return {"p_x": p[0], "p_y": p[1], "L_z": x["x"][0] * p[1] - x["x"][1] * p[0] + c["J"] * x["omega"]}

    @staticmethod
    def directors(q):
        """The body frame (n, 3, 3) at the angle q["phi"] (numbers, for pictures; the plane is z = 0)."""
        return planar_directors(np.asarray(q["phi"], dtype=float).reshape(-1))

    def box(self):
        """The square plate of the same mass and inertia, edges (a, a, 0): J = m a^2 / 6 (pictures)."""
        a = float(np.sqrt(6 * self.parameters.values["J"] / self.parameters.values["m"]))
        return (a, a, 0.0)

    frame = staticmethod(lambda q, offset=(): planar_frame(q, "x", offset))

    @staticmethod
    def initial(x, phi=0.0, v=(0.0, 0.0), omega=0.0):
        return {"x": _const(x), "phi": _const([phi]), "v": _const(v), "omega": _const([omega])}


class RigidBody:
    """Director-based 3D rigid body: mass m, principal moments of inertia J = (J_1, J_2, J_3) about
    the directors (d1, d2, d3) through the centre of mass."""
    point = True
    position = "x"
    kinematics = {"x": "v", "d1": "w1", "d2": "w2", "d3": "w3"}
    labels = {**{d: (f"director {d} (principal axis of inertia)", ("x", "y", "z")) for d in DIRECTORS},
              "v": ("velocity of the centre of mass", ("x", "y", "z")),
              **{w: (f"director rate {w} = d_t d{w[1]}", ("x", "y", "z")) for w in RATES},
              "lam": ("multipliers lambda_ij of the orthonormality constraints d_i . d_j = delta_ij",
                      ("11", "22", "33", "12", "13", "23"))}
    units = {"x": "m", **{d: "1" for d in DIRECTORS}, "v": "m/s", **{w: "1/s" for w in RATES}, "lam": "J"}   # SI
    supports = {}
    quadrature_degree = 0
    frame = staticmethod(lambda q, offset=(): director_frame(q, "x", offset))

    @staticmethod
    def default_initial():
        """A body placed without initial values: at the origin, d_i = e_i, at rest."""
        return RigidBody.initial((0.0, 0.0, 0.0))

    def __init__(self, mass, inertia):
        if not (np.isfinite(mass) and mass > 0):
            raise ValueError(f"mass must be a positive number (got {mass!r})")
        J = np.asarray(inertia, dtype=float)
        if J.shape != (3,) or not np.all(np.isfinite(J)) or np.any(J < 0):
            raise ValueError(f"inertia must be three principal moments >= 0 (got {inertia!r})")
        self.E = director_masses(J)
        self.parameters = ParameterSet(m=float(mass), **{f"E{i + 1}": e for i, e in enumerate(self.E)})
        v3 = (3,)
        self.fields = ([Field(n, "DG", 0, v3) for n in ("x", *DIRECTORS, "v", *RATES)] + [Field("lam", "DG", 0, (6,))])

    def _constants(self, domain):
        c = self.parameters.on(domain)
        return c["m"], [c[f"E{i + 1}"] for i in range(3)]

    def hamiltonian(self, x, dx, ds):
        """H = 1/2 m |v|^2 + 1/2 sum_i E_i |w_i|^2."""
        m, E = self._constants(dx.ufl_domain())
        return (0.5 * m * ufl.inner(x["v"], x["v"]) + sum(0.5 * e * ufl.inner(x[w], x[w]) for e, w in zip(E, RATES))) * dx

    def residual(self, step, test, dx, ds):
        """The equations of the module docstring at x_m (lambda at t_{n+1})."""
        m, E = self._constants(dx.ufl_domain())
        d = [step.mid(n) for n in DIRECTORS]
        w = [step.mid(n) for n in RATES]
        dw = [test[n] for n in RATES]
        lam = step.x1["lam"]
        F = ufl.inner(step.rate("x") - step.mid("v"), test["x"]) + m * ufl.inner(step.rate("v"), test["v"])
        F += sum(ufl.inner(step.rate(dn) - wi, test[dn]) + e * ufl.inner(step.rate(wn), dwi)
                 for dn, wn, wi, e, dwi in zip(DIRECTORS, RATES, w, E, dw))
        F += ufl.inner(lam, constraint_rate(d, dw)) + ufl.inner(constraint_rate(d, w), test["lam"])
        return F * dx

    @staticmethod
    def directors(q):
        """The body frame (n, 3, 3), columns d1, d2, d3 (numbers, for pictures)."""
        return np.stack([np.asarray(q[n], dtype=float).reshape(-1, 3) for n in DIRECTORS], axis=-1)

    def box(self):
        """Edges (a1, a2, a3) of the uniform box of the same mass and principal inertia (pictures):
        J_1 = m (a2^2 + a3^2) / 12, ..., i.e. a_k^2 = 12 E_k / m with the director masses E_k."""
        return tuple(float(np.sqrt(12 * e / self.parameters.values["m"])) for e in self.E)

    def compatible_strains(self, x):
        return {}

    # statics and modes (rodfem/analysis/statics.py): d_i . d_j - delta_ij = 0 replaces the velocity-level row
    static_fields = ("lam",)

    def static_rows(self, x, ref, test, dx, ds):
        return ufl.inner(orthonormality([x[n] for n in DIRECTORS]), test["lam"]) * dx

    def momentum(self, x):
        """p = m v, L = x x m v + sum_i E_i d_i x w_i (about the origin)."""
        m, E = self._constants(ufl.domain.extract_unique_domain(x["v"]))
        p = m * x["v"]
        L = ufl.cross(x["x"], p) + sum((e * ufl.cross(x[dn], x[wn]) for e, dn, wn in zip(E, DIRECTORS, RATES)), ufl.zero(3))
        return {**{f"p_{c}": p[i] for i, c in enumerate("xyz")}, **{f"L_{c}": L[i] for i, c in enumerate("xyz")}}

    @staticmethod
    def initial(x, R=None, v=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0)):
        """Initial values: position x, rotation R = [d1 d2 d3], velocity v, angular velocity omega (spatial)."""
        R = np.eye(3) if R is None else np.asarray(R, dtype=float)
        omega = np.asarray(omega, dtype=float)
        init = {"x": _const(x), "v": _const(v)}
        for i, (dn, wn) in enumerate(zip(DIRECTORS, RATES)):
            init[dn] = _const(R[:, i])
            init[wn] = _const(np.cross(omega, R[:, i]))
        return init


def _const(value):
    value = np.asarray(value, dtype=float).ravel()
    return lambda x: np.outer(value, np.ones(x.shape[1])) if len(value) > 1 else np.full(x.shape[1], value[0])
