"""One body of a mechanism: a model on its own mesh, with its state, step residual and ports.

A flexible body (rod, beam, string) lives on an interval mesh of [0, L]; a
rigid body (a model with ``point = True``) on a mesh of one unit cell, where
its fields are cellwise constant (DG0) and int f dx = f.  A `Body` builds
the UFL forms of one time step and compiles nothing: a `Problem` (one body)
or a `System` (bodies joined by joints) compiles the forms of all its bodies
together and solves them with one Newton.

Only what the body uses is built: the loads it lists, the supports it lists,
the tip only if the end s = L is free (else the mean position
(1/L) int r ds), momentum maps only if nothing is supported.

An INTERACTION (the `contacts` a body lists, e.g. forms/contact.py: contact with an obstacle and
its friction) is a port with an energy and a dissipation of its own, terminated inside the body:

``bind(body)``                      check the body's fields, make its constants
``energy(x, dx, ds)``               its stored energy, a UFL form (joins H)
``residual(step, test, dx, ds)``    its forces in the balance rows (joins F)
``dissipation(step, dx, ds)``       h d_n >= 0 of the step (UFL), or None
``observables(x, dx, ds)``          dict column -> UFL functional (its forces)
``monitor(body)``                   optional: dict column -> number of the state x_{n+1},
                                    computed from the dofs (collective), e.g. a largest penetration

so that H_{n+1} - H_n + dissipated = supplied holds with it exactly when its residual does the
work energy_{n+1} - energy_n - dissipated on the step.
"""
import functools

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from rodfem.core.integrators import RULES, Step
from rodfem.core.ports import ENDS
from rodfem.core.spaces import StateSpace, dofs_per_element
from rodfem.fem.jit import compiles


class Body:
    """The discrete PH system of `model` on [0, L] with `n_elements` cells (or one rigid body).

    initial: dict field -> callable x -> values (x[0] = s) or UFL expression;
             strains not given are set from model.compatible_strains.
    n_elements (a flexible body): a whole number, at least the number of MPI ranks, small enough to fit in memory.
    """

    @compiles  # the elements and the initial values' expressions: under the JIT cache lock
    def __init__(self, model, length=1.0, n_elements=1, loads=(), supports=(), initial=None,
                 integrator="midpoint", comm=MPI.COMM_WORLD, name="", contacts=(), shared=None):
        """shared: a rodfem.core.kinds.Meshes of the system, whose bodies of the same number of cells,
        length and fields then share one mesh and one state space (None: a mesh of its own)."""
        self.model, self.name = model, name
        self.rigid = bool(getattr(model, "point", False))
        if self.rigid:
            length, n_elements = 1.0, 1
            if supports:
                raise ValueError(f"body {name or model}: a rigid body has no ends to support; "
                                 "fix it with a joint to GROUND")
        if shared is None:
            from rodfem.core.kinds import Meshes
            shared = Meshes()
        self.shared = shared
        self.length = float(length)
        self.n_elements = 1 if self.rigid else shared.elements(n_elements, dofs_per_element(model.fields), comm)
        self.loads, self.supports, self.integrator = list(loads), list(supports), integrator
        self.contacts = list(contacts)
        if integrator not in RULES:
            raise ValueError(f"integrator must be one of {', '.join(RULES)} (got {integrator!r})")
        self.mesh, self.facets, self.end_tags = shared.mesh(comm, self.n_elements, self.length)
        self.comm = self.mesh.comm
        self.space = S = shared.space(self.mesh, RigidSpace if self.rigid else StateSpace, model.fields)
        self.x0, self.x1, self.state0 = (fem.Function(S.V) for _ in range(3))
        self.h = fem.Constant(self.mesh, 1.0)

        self.dx = ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": model.quadrature_degree})
        self.ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.end_tags)
        # no initial values: the model's own default (a rod straight along x at rest), where it has one
        self._set_initial(initial or (model.default_initial() if hasattr(model, "default_initial") else {}))
        for load in self.loads:
            load.bind(self.mesh, S)
        self.bcs = [bc for sup in self.supports for bc in sup.conditions(S, model, self.facets, self.state0)]
        for contact in self.contacts:
            contact.bind(self)

    @functools.cached_property
    def step(self):
        """The UFL view of a step (rodfem/core/integrators.py), made when a form is first built."""
        return Step(self.space.split(self.x0), self.space.split(self.x1), self.h, self.integrator)

    # -- the forms of one step (UFL, not compiled) ------------------------------
    def residual_form(self):
        """E (x_{n+1} - x_n)/h - J z - B u, tested: the model's residual and its loads' input maps."""
        test = self.space.split(ufl.TestFunction(self.space.V))
        F = self.model.residual(self.step, test, self.dx, self.ds)
        for load in self.loads:
            F += load.input_map(self.step, test, self.dx, self.ds)
        for contact in self.contacts:
            F += contact.residual(self.step, test, self.dx, self.ds)
        return F

    def forms(self, prefix=""):
        """dict of the UFL forms a run needs: F, J = dF/dx_{n+1}, H(x_{n+1}), the supplied work h y.u
        (None without loads), the observables ('obs:' + column name) and, only for a
        dissipating model, 'dissipation' = h d_n (rodfem/core/model.py)."""
        F = self.residual_form()
        powers = [load.power(self.step, self.dx, self.ds) for load in self.loads]
        X1 = self.space.split(self.x1)
        H = self.model.hamiltonian(X1, self.dx, self.ds)
        for contact in self.contacts:   # the interactions' stored energies
            H += contact.energy(X1, self.dx, self.ds)
        forms = {"F": F, "J": ufl.derivative(F, self.x1), "H": H,
                 "work": self.h * sum(powers[1:], powers[0]) if powers else None,
                 **{"obs:" + prefix + k: v for k, v in self.observables(X1).items()}}
        dissipation = self.dissipation_form()
        if dissipation is not None:   # only a dissipating model has (and compiles) this form
            forms["dissipation"] = dissipation
        return forms

    def dissipation_form(self):
        """h d_n, the energy the step dissipates (UFL), or None: the model's optional `dissipation`
        and that of the interactions."""
        dissipation = getattr(self.model, "dissipation", None)
        terms = [dissipation(self.step, self.dx, self.ds)] if dissipation is not None else []
        terms += [c.dissipation(self.step, self.dx, self.ds) for c in self.contacts]
        terms = [t for t in terms if t is not None]
        return sum(terms[1:], terms[0]) if terms else None

    def algebraic_fields(self):
        """The fields whose x_n the step's residual does not read: multipliers at t_{n+1} (e.g. of an
        orthonormality constraint), unknowns of each step rather than states with a memory.  Read off the UFL
        graph of the residual: x_n enters only through its components x_n[k] (`StateSpace.split`); a field none
        of whose components appears is algebraic.  (A field read as a whole x_n counts as read.)"""
        from ufl.classes import FixedIndex, Indexed
        from ufl.corealg.traversal import unique_pre_traversal
        read, whole = set(), False
        for integral in self.residual_form().integrals():
            for node in unique_pre_traversal(integral.integrand()):
                if not any(op == self.x0 for op in node.ufl_operands):
                    continue
                idx = node.ufl_operands[1] if isinstance(node, Indexed) else ()
                if idx and all(isinstance(i, FixedIndex) for i in idx):
                    read.add(int(idx[0]))
                else:
                    whole = True
        if whole:
            return []
        out, k = [], 0
        for f in self.space.fields:
            if not read & set(range(k, k + f.size)):
                out.append(f.name)
            k += f.size
        return out

    # -- set-up -------------------------------------------------------------
    def _set_initial(self, initial):
        S = self.space
        unknown = set(initial) - set(S.names)
        if unknown:
            raise ValueError(f"initial values for unknown fields {sorted(unknown)}; fields are {S.names}")
        for name, value in initial.items():
            if not isinstance(value, ufl.core.expr.Expr):
                S.assign(self.x0, name, value)
        for name, value in initial.items():
            if isinstance(value, ufl.core.expr.Expr):
                S.assign(self.x0, name, value)
        for name, expr in self.shared.strains(self, initial):
            S.assign(self.x0, name, expr)
        self.x1.x.array[:] = self.x0.x.array
        self.state0.x.array[:] = self.x0.x.array

    def observables(self, X):
        """Columns of the history as UFL functionals of the state X (= x_{n+1})."""
        obs = {}
        supported = {sup.end for sup in self.supports}
        pos = X[self.model.position]
        axes = "xyz"[: pos.ufl_shape[0]]
        if self.rigid:      # the body's position (the unit cell: int x dx = x)
            for i, c in enumerate(axes):
                obs[c] = pos[i] * self.dx
        elif "right" not in supported:
            for i, c in enumerate(axes):
                obs[f"tip_{c}"] = pos[i] * self.ds(ENDS["right"])
        else:  # no free end: the mean position (1/L) int r ds shows how the body moves
            for i, c in enumerate(axes):
                obs[f"mean_{c}"] = pos[i] / self.length * self.dx
        if not supported:
            obs.update(self.momentum_forms(X))
        if hasattr(self.model, "columns"):   # a model's own columns (e.g. entropy, mean temperature)
            obs.update(self.model.columns(X, self.dx, self.ds, self.length))
        for load in self.loads:   # a port may add columns of its own (an actuator's length or volume)
            if hasattr(load, "observables"):
                obs.update(load.observables(X, self.dx, self.ds))
        obs.update(self.interaction_forms(X))
        return obs

    def interaction_forms(self, X):
        """The interactions' columns (their forces) as functionals of the state X."""
        obs = {}
        for contact in self.contacts:
            obs.update(contact.observables(X, self.dx, self.ds))
        return obs

    def monitor(self):
        """The interactions' numeric columns of x_{n+1} (collective)."""
        out = {}
        for contact in self.contacts:
            if hasattr(contact, "monitor"):
                out.update(contact.monitor(self))
        return out

    def momentum_forms(self, X):
        """The momentum maps (p_x, ..., L_z) of the model as functionals."""
        return {name: density * self.dx for name, density in self.model.momentum(X).items()}

    # -- one time step ------------------------------------------------------
    def set_time(self, t):
        """Inputs u(t) for the step (t = t_{n+1/2})."""
        for load in self.loads:
            load.update(t)

    @property
    def dofs(self):
        im = self.space.V.dofmap.index_map
        return im.size_global * self.space.V.dofmap.index_map_bs

    def describe_elements(self):
        return {f.name: f"{f.family}{f.degree}" + (f"^{f.shape[0]}" if f.shape else "") for f in self.space.fields}


class RigidSpace(StateSpace):
    """The state space of a rigid body (DG0 fields on a mesh of one cell), read and written without
    collapsing subspaces: DOLFINx 0.5.2 segfaults when it collapses a subspace of a mixed space that
    has a scalar field on a rank without cells (the body's one cell lives on one rank, so
    `mpirun -n 2` crashed for the planar rigid body).  Each field component has one dof, on the
    rank that owns the cell (found with locate_dofs_topological on the subspace views)."""

    def field_dofs(self, name):
        """Local dofs of field `name` in W, one per component (empty on the ranks without the cell);
        found once per field (a history column reads them every step)."""
        known = self.__dict__.setdefault("_field_dofs", {})
        if name not in known:
            known[name] = self._locate_field_dofs(name)
        return known[name]

    def _locate_field_dofs(self, name):
        cells = np.arange(self.mesh.topology.index_map(self.mesh.topology.dim).size_local, dtype=np.int32)
        sub = self.sub(name)
        subs = [sub.sub(c) for c in range(self.field(name).size)] if self.field(name).shape else [sub]
        return np.concatenate([fem.locate_dofs_topological(V, self.mesh.topology.dim, cells) for V in subs])

    def _midpoint(self):
        """The cell's midpoint [3, 1] (none where the cell is not owned); the mesh never moves: found once."""
        if "_mid" not in self.__dict__:
            self._mid = self._locate_midpoint()
        return self._mid

    def _locate_midpoint(self):
        x = self.mesh.geometry.x
        return (np.array([[0.5 * (x[:, 0].min() + x[:, 0].max())], [0.0], [0.0]]) if len(x)
                else np.zeros((3, 0)))

    def assign(self, u, name, value):
        """Set field `name` of u to `value` (a callable x -> values, evaluated at the cell's midpoint,
        or a constant)."""
        if isinstance(value, ufl.core.expr.Expr):
            return super().assign(u, name, value)
        if not callable(value):
            value = self._constant(name, value)
        dofs = self.field_dofs(name)
        if len(dofs):
            u.x.array[dofs] = np.asarray(value(self._midpoint()), dtype=float).reshape(-1)
        u.x.scatter_forward()

    def nodal(self, u, name):
        """(s, values[npoints, size]): the cell midpoint and the field's value, where the cell is owned."""
        dofs = self.field_dofs(name)
        if not len(dofs):
            return np.zeros(0), np.zeros((0, self.field(name).size))
        return self._midpoint()[0], u.x.array[dofs].reshape(1, -1)
