"""A scene made concrete: mesh, state space, step residual, ports and observables.

Only what the scene uses is assembled: the loads it lists, the supports it
lists, the tip only if the end s = L is free (else the mean position
(1/L) int r ds), momentum maps only if nothing is supported.
"""
import numpy as np
import ufl
from dolfinx import fem, mesh as dmesh
from mpi4py import MPI

from . import compat
from .integrators import Step
from .jitcache import compiles
from .limits import check_elements
from .newton import Newton
from .ports import ENDS
from .spaces import StateSpace, dofs_per_element


class Problem:
    """The discrete PH system of `model` on [0, L] with `n_elements` cells.

    initial: dict field -> callable x -> values (x[0] = s) or UFL expression;
             strains not given are set from model.compatible_strains.
    n_elements: a whole number, at least the number of MPI ranks, small enough to fit in memory.
    `t` is the time of the state x_n (0 at the start; the time loop advances it).
    """

    @compiles
    def __init__(self, model, length, n_elements, loads=(), supports=(), initial=None,
                 integrator="midpoint", comm=MPI.COMM_WORLD, newton_options=None):
        self.model, self.length, self.t = model, float(length), 0.0
        self.n_elements = check_elements(n_elements, dofs_per_element(model.fields), comm)
        self.loads, self.supports, self.integrator = list(loads), list(supports), integrator
        self.mesh = dmesh.create_interval(comm, self.n_elements, [0.0, self.length])
        self.comm = self.mesh.comm
        self.space = S = StateSpace(self.mesh, model.fields)
        self.x0, self.x1, self.state0 = (fem.Function(S.V) for _ in range(3))
        self.h = fem.Constant(self.mesh, 1.0)

        self._tag_ends()
        self.dx = ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": model.quadrature_degree})
        self.ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.end_tags)
        self._set_initial(initial or {})

        X0, X1 = S.split(self.x0), S.split(self.x1)
        self.step = Step(X0, X1, self.h, integrator)
        test = S.split(ufl.TestFunction(S.V))
        for load in self.loads:
            load.bind(self.mesh, S)
        F = model.residual(self.step, test, self.dx, self.ds)
        for load in self.loads:
            F += load.input_map(self.step, test, self.dx, self.ds)
        # Build every UFL form first, then compile: UFL's signatures (the JIT cache keys)
        # depend on global counters that a compilation advances, so compiling F before
        # J is even built would give J a different key in a cold and a warm process.
        powers = [load.power(self.step, self.dx, self.ds) for load in self.loads]
        forms = {"F": F, "J": ufl.derivative(F, self.x1), "H": model.hamiltonian(X1, self.dx, self.ds),
                 "work": self.h * sum(powers[1:], powers[0]) if powers else None,
                 **{"obs:" + k: v for k, v in self._observables(X1).items()}}
        for f in forms.values():
            if f is not None:
                f.signature()  # computed (and kept by UFL) before any compilation
        compiled = {k: compat.form(f) if f is not None else None for k, f in forms.items()}
        self.F, self.J, self.H, self.work = (compiled[k] for k in ("F", "J", "H", "work"))
        self.observables = {k[4:]: f for k, f in compiled.items() if k.startswith("obs:")}
        bcs = [bc for sup in self.supports for bc in sup.conditions(S, model, self.facets, self.state0)]
        self.newton = Newton(self.F, self.J, self.x1, bcs, options=newton_options)

    # -- set-up -------------------------------------------------------------
    def _tag_ends(self):
        m = self.mesh
        m.topology.create_connectivity(0, 1)
        self.facets = {
            "left": dmesh.locate_entities_boundary(m, 0, lambda x: np.isclose(x[0], 0.0)),
            "right": dmesh.locate_entities_boundary(m, 0, lambda x: np.isclose(x[0], self.length)),
        }
        idx = np.concatenate([self.facets["left"], self.facets["right"]]).astype(np.int32)
        vals = np.concatenate([np.full(len(self.facets["left"]), ENDS["left"]),
                               np.full(len(self.facets["right"]), ENDS["right"])]).astype(np.int32)
        order = np.argsort(idx)
        self.end_tags = dmesh.meshtags(m, 0, idx[order], vals[order])

    def _set_initial(self, initial):
        S = self.space
        unknown = set(initial) - set(S.names)
        if unknown:
            raise ValueError(f"initial values for unknown fields {sorted(unknown)}; fields are {S.names}")
        for name, value in initial.items():
            if not isinstance(value, ufl.core.expr.Expr):
                S.assign(self.x0, name, value)
        X0 = S.split(self.x0)
        for name, value in initial.items():
            if isinstance(value, ufl.core.expr.Expr):
                S.assign(self.x0, name, value)
        for name, expr in self.model.compatible_strains(X0).items():
            if name not in initial:
                S.assign(self.x0, name, expr)
        self.x1.x.array[:] = self.x0.x.array
        self.state0.x.array[:] = self.x0.x.array

    def _observables(self, X):
        obs = {}
        supported = {sup.end for sup in self.supports}
        pos = X[self.model.position]
        axes = "xyz"[: pos.ufl_shape[0]]
        if "right" not in supported:
            for i, c in enumerate(axes):
                obs[f"tip_{c}"] = pos[i] * self.ds(ENDS["right"])
        else:  # no free end: the mean position (1/L) int r ds shows how the body moves
            for i, c in enumerate(axes):
                obs[f"mean_{c}"] = pos[i] / self.length * self.dx
        if not supported:
            for name, density in self.model.momentum(X).items():
                obs[name] = density * self.dx
        return obs

    # -- one time step (the time loop's view of a problem) -------------------
    def set_time(self, t):
        """Inputs u(t) for the step (t = t_{n+1/2})."""
        for load in self.loads:
            load.update(t)

    def predict(self, previous):
        """Newton's start: x_{n+1}^0 = 2 x_n - x_{n-1} (x_n if `previous` is None)."""
        if previous is None:
            self.x1.x.array[:] = self.x0.x.array
        else:
            self.x1.x.array[:] = 2.0 * self.x0.x.array - previous

    def solve(self, step, t):
        """x_{n+1} by Newton (raises NewtonFailure)."""
        return self.newton.solve(step, t)

    def accept(self):
        """x_n <- x_{n+1}; returns the old x_n (for the next prediction)."""
        previous = self.x0.x.array.copy()
        self.x0.x.array[:] = self.x1.x.array
        return previous

    # -- evaluation ---------------------------------------------------------
    def assemble(self, compiled):
        return self.comm.allreduce(fem.assemble_scalar(compiled), op=MPI.SUM)

    def supplied_work(self):
        """h y.u of the last step, with u at t_{n+1/2} and y = flow_{n+1/2}."""
        return self.assemble(self.work) if self.work is not None else 0.0

    def hamiltonian(self):
        """H(x_{n+1})."""
        return self.assemble(self.H)

    def observe(self):
        return {k: self.assemble(f) for k, f in self.observables.items()}

    @property
    def dofs(self):
        im = self.space.V.dofmap.index_map
        return im.size_global * self.space.V.dofmap.index_map_bs

    def describe_elements(self):
        return {f.name: f"{f.family}{f.degree}" + (f"^{f.shape[0]}" if f.shape else "") for f in self.space.fields}
