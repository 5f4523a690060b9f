"""The static equilibrium of a string alone (a helper of the cable demos).

The string's own static problem in r only (the strains and velocities follow from it), solved by
Newton: cheaper than the generic statics of rodfem.analysis.statics, which solves for every
field of the discrete model, and the way the cable scenes find their hanging start.
"""
import numpy as np
import ufl
from dolfinx import fem

from rodfem.fem.jit import compile_forms
from rodfem.forms.string import relaxed, set_state
from rodfem.nls.newton import Newton


def static_equilibrium(problem, t=0.0, supports=None, options=None):
    """Put problem.x0 at rest in the discrete static equilibrium under its loads at time t.

    Solves for r in P1^3 (starting from the current r, which must be in
    tension where the tangent stiffness would vanish otherwise)

        int 2 W'(|d_s r|^2) d_s r . d_s dr ds = sum of the loads' int u.dr   (supports: fixed r)

    and sets C = |d_s r|^2, v = 0 and the Maxwell branches relaxed (C_k = 1: the
    equilibrium of a load held for long; W is the equilibrium branch's).  This is exactly the step equations with
    x_{n+1} = x_n, v = 0: an equilibrium found here stays at rest to solver
    tolerance.  Only loads with the default pairing (u.v) are supported.
    `supports` (default: the problem's) fix r in the static solve; they must
    remove the rigid motions the loads do not (e.g. a crane trolley free to
    roll is held for the static solve).  Returns the number of Newton iterations.
    """
    model, S = problem.model, problem.space
    Vr, rdofs = S.collapse("r")
    r = fem.Function(Vr)
    r.x.array[:] = problem.x0.x.array[rdofs]
    r0 = fem.Function(Vr)
    r0.x.array[:] = r.x.array
    dr = ufl.TestFunction(Vr)
    dom = problem.dx.ufl_domain()
    C = ufl.variable(ufl.inner(r.dx(0), r.dx(0)))
    F = 2 * ufl.diff(model.W(C, dom), C) * ufl.inner(r.dx(0), dr.dx(0)) * problem.dx
    for load in problem.loads:
        if load.pairing is not None or load.flow != "v":
            raise ValueError(f"static_equilibrium: load {load.name} is not a plain force on v")
        u = fem.Constant(problem.mesh, np.asarray(load.value(t), dtype=float))
        F -= ufl.inner(u, dr) * load.measure(problem.dx, problem.ds)
    bcs = []
    for sup in (problem.supports if supports is None else supports):
        for name in model.supports[sup.kind]:
            base, _, comp = name.partition(".")
            if base != "r":
                continue
            sub = Vr if not comp else Vr.sub(int(comp))
            dofs = fem.locate_dofs_topological(sub, 0, problem.facets[sup.end])
            bcs.append(fem.dirichletbc(r0, dofs))
    compiled = compile_forms({"F": F, "J": ufl.derivative(F, r)})   # under the JIT cache lock
    newton = Newton(compiled["F"], compiled["J"], r, bcs, options=options, prefix="rodfem_static_")
    solve = newton.solve(0, t)
    problem.x0.x.array[rdofs] = r.x.array
    S.assign(problem.x0, "v", lambda x: np.zeros((3, x.shape[1])))
    S.assign(problem.x0, "C", ufl.inner(r.dx(0), r.dx(0)))
    for k in range(1, len(getattr(model, "branches", ())) + 1):   # long held: Maxwell branches relaxed
        S.assign(problem.x0, f"C_{k}", relaxed)
    set_state(problem)
    return solve.iterations
