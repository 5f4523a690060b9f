# Shared pieces of the 3D Cosserat rod demos: material parameters (as
# compliances, so that 0 switches a strain off), the straight initial rod
# with an optional rigid motion, the two kinds of end moment, a smooth load
# ramp for load-stepped statics, and a nodal orthonormality check.
import numpy as np

from rodfem import Load
from rodfem.app.scene import Parameter, density
from rodfem.errors import ParameterError
from rodfem.forms import cosserat_rod, rod_materials

# Newton options of the 3D rod scenes: a chord Newton that reuses the
# Jacobian and its LU over up to 8 iterations, across steps (the 102 x 102
# element matrices make assembly + LU the cost: 3-4x faster per step than
# full Newton, same converged steps).  If it fails in a step, the engine
# repeats that step with full Newton (rodfem/nls/newton.py).  The chord iteration
# converges linearly, so it is driven to |F| <= 1e-12 (a few extra cheap solves)
# to keep the balance error at the full-Newton level.
NEWTON = {"snes_lag_jacobian": 8, "snes_lag_jacobian_persists": True, "snes_atol": 1e-12}


def compliance(name, default, unit, doc):
    """A compliance C >= 0 (0: the strain is constrained)."""
    return Parameter(name, default, unit, doc, low=0)


def material_parameters(EA, GA, GJ, EI, rhoA, rhoJ, kappa_lock=10.0, delta=1.0):
    """The material law (forms/rod_materials.py) with C_N = (1/EA, 1/GA, 1/GA), C_M = (1/GJ, 1/EI, 1/EI)
    (small-strain; the axial one in tension for 'asymmetric') and each law's own parameters,
    line density rhoA, rotary inertia rhoJ_1..3."""
    return [
        Parameter("material", "linear", "", "complementary energy W*(N, M) (forms/rod_materials.py)",
                  choices=tuple(rod_materials.MATERIALS)),
        Parameter("coupling", 0.5, "", "stretch-twist: C_NM = coupling sqrt(C_N1 C_M1)", low=-1, high=1),
        Parameter("kappa_lock", kappa_lock, "1/m", "stiffening: locking curvature of the bending law",
                  low=0, low_open=True),
        Parameter("compression_ratio", 4.0, "", "asymmetric: axial compliance in compression / in tension",
                  low=0, low_open=True),
        Parameter("delta", delta, "N", "asymmetric: width of the tension-compression transition in N_1",
                  low=0, low_open=True),
        compliance("C_N1", 1.0 / EA, "1/N", "axial compliance 1/EA (0: inextensible)"),
        compliance("C_N2", 1.0 / GA, "1/N", "shear compliance 1/GA_2 (0: shear-rigid)"),
        compliance("C_N3", 1.0 / GA, "1/N", "shear compliance 1/GA_3 (0: shear-rigid)"),
        compliance("C_M1", 1.0 / GJ, "1/(N m^2)", "torsional compliance 1/GJ (0: no torsion)"),
        compliance("C_M2", 1.0 / EI, "1/(N m^2)", "bending compliance 1/EI_2"),
        compliance("C_M3", 1.0 / EI, "1/(N m^2)", "bending compliance 1/EI_3"),
        density("rhoA", rhoA, "kg/m", "mass per length (0 with rhoJ = 0: statics)"),
        density("rhoJ1", rhoJ[0], "kg m", "rotary inertia per length about the axis d1"),
        density("rhoJ2", rhoJ[1], "kg m", "rotary inertia per length about d2"),
        density("rhoJ3", rhoJ[2], "kg m", "rotary inertia per length about d3"),
    ]


def rod(p):
    """The CosseratRod of the parameters p."""
    J = [p["rhoJ1"], p["rhoJ2"], p["rhoJ3"]]
    try:
        cosserat_rod.director_masses(J)
    except ValueError:
        raise ParameterError(f"parameters 'rhoJ1..3' must satisfy rhoJ_k <= sum of the other two (got {J})") from None
    return cosserat_rod.CosseratRod(p["rhoA"], J, material=material(p))


def material(p):
    """The rod material of the parameters p (a one-line ParameterError if they do not fit the law)."""
    C = {k: p[k] for k in rod_materials.COMPLIANCES}
    name = p.get("material", "linear")
    extra = {"linear": {}, "stretch-twist": {"C_NM": p.get("coupling", 0.0) * np.sqrt(C["C_N1"] * C["C_M1"])},
             "stiffening": {"kappa_lock": p.get("kappa_lock")},
             "asymmetric": {"C_N1c": p.get("compression_ratio", 1.0) * C["C_N1"], "delta": p.get("delta")}}[name]
    try:
        return rod_materials.MATERIALS[name](**C, **extra)
    except ValueError as e:
        raise ParameterError(f"parameter 'material' = {name}: {e}") from None


def straight(start, directors, omega=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0)):
    """Initial values of a straight rod r(s) = start + s d1, with the rigid motion v = velocity + omega x r, w_i = omega x d_i."""
    start, omega, velocity = (np.asarray(a, float) for a in (start, omega, velocity))

    def const(vec):
        return lambda x: np.outer(vec, np.ones(x.shape[1]))

    def r(x):
        return start[:, None] + np.outer(directors[0], x[0])
    init = {"r": r, "v": lambda x: velocity[:, None] + np.cross(omega, r(x).T).T}
    for i, d in enumerate(directors):
        init[f"d{i + 1}"] = const(d)
        init[f"w{i + 1}"] = const(np.cross(omega, d))
    return init


def end_moment(value, frame="spatial", where="right", name="end moment"):
    """A moment load: 'spatial' (m fixed in space) or 'body' (components on d1, d2, d3)."""
    pairing = {"spatial": cosserat_rod.spatial_moment, "body": cosserat_rod.body_moment}[frame]
    return Load("w1", value, where, f"{name} ({frame})", pairing=pairing)


def smooth_ramp(value, t_ramp):
    """u(t) = value s(t/t_ramp), s = 10 t^3 - 15 t^4 + 6 t^5 (s', s'' = 0 at both ends).

    Load-stepped statics with the midpoint rule puts the MIDPOINT states in
    equilibrium; the end state then carries an alternating error
    ~ h^2 d^2q/dt^2 at t_end, which this ramp switches off (d^2 q / dt^2 = 0 there).
    """
    value = np.asarray(value, dtype=float)

    def u(t):
        tau = min(max(t / t_ramp, 0.0), 1.0)
        return value * tau**3 * (10 - 15 * tau + 6 * tau**2)
    return u


def orthonormality_error(problem, state=None):
    """max over the owned nodes of |R^T R - I| (R = [d1 d2 d3]) of x_{n} (or `state`), all ranks."""
    from mpi4py import MPI
    S, u = problem.space, state if state is not None else problem.x0
    R = np.stack([S.nodal(u, n)[1] for n in cosserat_rod.DIRECTORS], axis=2)
    local = float(np.max(np.abs(np.einsum("nki,nkj->nij", R, R) - np.eye(3)))) if len(R) else 0.0
    return problem.comm.allreduce(local, op=MPI.MAX)
