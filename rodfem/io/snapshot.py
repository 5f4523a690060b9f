"""What a frame shows of one body, gathered on rank 0 from every rank's part of the mesh.

For a flexible body: the nodes of its position's element (P_k: k per cell, in order of s) with
the nodal state fields there, the section frame [d1 d2 d3] if the model has one
(``model.directors``), and the model's derived fields (``model.outputs``: strains, stress
resultants) evaluated cell by cell at 2k + 1 evenly spaced points of every cell (its k + 1
nodes and the k midpoints between them), exactly as the discrete fields are there, also where
they jump between cells.  For a rigid body: its one point, fields and frame.

Velocities of a model without inertia (``model.massless``: statics through the integrator) are
left out: there they are only the integrator's alternating by-product, not the body's motion.
The values are those of the state on whichever rank owns them: the same state gives the same
snapshot on any number of ranks.
"""
from dataclasses import dataclass, field

import numpy as np
from dolfinx import fem

from rodfem.fem import compat
from rodfem.fem.jit import locked


def spatial(values, dim):
    """Vectors of a `dim`-dimensional model (n, dim) as 3-vectors (n, 3)."""
    if values.shape[1] == 3 or dim == 3:
        return values
    return np.column_stack([values, np.zeros((len(values), 3 - values.shape[1]))])


@dataclass
class BodyState:
    """One body at one time, on rank 0.

    kind: "rod" (a section frame), "line" (a string: no section), "box" (a rigid body with a
    frame) or "point" (a point mass).  position (n, 3) at the arc lengths s (n,); fields: nodal
    state fields (n, size); directors (n, 3, 3) (columns d1, d2, d3) or None; cells: the derived
    fields at the 2k + 1 points of every cell, {name: (cells, 2k + 1, size)}, with "s" among them.
    """
    name: str
    kind: str
    dim: int
    s: np.ndarray
    position: np.ndarray
    fields: dict
    directors: np.ndarray = None
    cells: dict = field(default_factory=dict)
    degree: int = 1
    box: tuple = None
    link: np.ndarray = None     # a rigid body drawn as a link: its points (k, 3) in the body frame


class BodyView:
    """The output's view of one body (a flexible or rigid body of a Problem or a System)."""

    def __init__(self, name, body):
        self.name, self.body, self.model = name, body, body.model
        S = body.space
        pos = S.field(self.model.position)
        self.dim, self.degree = pos.size, pos.degree
        rates = set(getattr(self.model, "kinematics", {}).values())
        self.omitted = sorted(rates & set(S.names)) if getattr(self.model, "massless", False) else []
        self.nodal = [f.name for f in S.fields if f.family == pos.family and f.degree == pos.degree
                      and f.name != pos.name and f.name not in self.omitted]
        self.rates = [n for n in getattr(self.model, "kinematics", {}).values() if n in self.nodal]
        velocity = getattr(self.model, "kinematics", {}).get(self.model.position)
        self.velocity = velocity if velocity in self.nodal else None     # (None: omitted or none)
        self.has_frame = hasattr(self.model, "directors")
        self.kind = ("box" if self.has_frame else "point") if body.rigid else ("rod" if self.has_frame else "line")
        self._outputs = None   # (fem.Expression, [(name, size)]), made at the first frame

    @property
    def labels(self):
        return getattr(self.model, "labels", {})

    @property
    def units(self):
        """{array: SI unit} of everything the files hold for this body ("1": dimensionless)."""
        units = dict(getattr(self.model, "units", {}))
        position = units.get(self.model.position, "m")
        return {"s": position, "speed": units.get(self.velocity, ""), "d1": "1", "d2": "1", "d3": "1",
                **units, "points": position}

    def output_names(self):
        """[(name, size)] of the model's derived fields (flexible bodies)."""
        return self._compile()[1] if not self.body.rigid else []

    def _compile(self):
        """The model's outputs as one compiled expression at the 2k + 1 points of a cell (collective)."""
        if self._outputs is None:
            import ufl
            S, body = self.body.space, self.body
            x = ufl.SpatialCoordinate(body.mesh)
            exprs = dict(self.model.outputs(S.split(body.x0))) if hasattr(self.model, "outputs") else {}
            parts, names = [x[0]], [("s", 1)]
            for name, e in exprs.items():
                comps = [e[i] for i in range(e.ufl_shape[0])] if e.ufl_shape else [e]
                parts += comps
                names.append((name, len(comps)))
            points = np.linspace(0.0, 1.0, 2 * self.degree + 1)[:, None]
            compat.settle_coordinate_element(body.mesh)   # the same cache key in a cold and a warm run
            with locked(body.comm):
                expr = fem.Expression(ufl.as_vector(parts), points)
            self._outputs = (expr, names)
        return self._outputs

    def gather(self):
        """The BodyState on rank 0 (None on the other ranks).  Collective."""
        body, S = self.body, self.body.space
        local = {n: S.nodal(body.x0, n) for n in [self.model.position, *self.nodal]}
        cells = None
        if not body.rigid:
            expr, names = self._compile()
            ncells = body.mesh.topology.index_map(body.mesh.topology.dim).size_local
            cells = compat.eval_expression(expr, body.mesh, np.arange(ncells, dtype=np.int32))
            cells = cells.reshape(ncells, 2 * self.degree + 1, -1)
        gathered = _gathered(body.comm, local, cells) if body.comm.size > 1 else [(local, cells)]
        if body.comm.rank != 0:
            return None
        pos_name = self.model.position
        s = np.concatenate([g[0][pos_name][0] for g in gathered])
        order = np.argsort(s, kind="stable")
        values = {n: np.concatenate([g[0][n][1] for g in gathered])[order] for n in local}
        position = spatial(values.pop(pos_name), self.dim)
        state = BodyState(self.name, self.kind, self.dim, s[order], position, values, degree=self.degree)
        if self.has_frame:
            state.directors = np.asarray(self.model.directors({pos_name: position, **values}), dtype=float)
        if cells is not None:
            state.cells = by_name(np.concatenate([g[1] for g in gathered]), self._outputs[1])
        if body.rigid and hasattr(self.model, "box"):
            state.box = tuple(self.model.box())
        if body.rigid and getattr(self.model, "link", None) is not None:
            state.link = np.asarray(self.model.link, dtype=float)
        return state


    def facts(self):
        """What the writer needs to know of this body besides its model (plain values, to send to
        rank 0 when the body is built on another rank)."""
        return {"dim": self.dim, "degree": self.degree, "omitted": self.omitted, "nodal": self.nodal,
                "rates": self.rates, "velocity": self.velocity, "has_frame": self.has_frame, "kind": self.kind,
                "outputs": self.output_names()}


def _gathered(comm, local, cells):
    """[(local, cells)] of every rank on rank 0 (None elsewhere): `local` {name: (s, values)}, `cells` an array
    or None, the same names and trailing shapes on every rank.  Their arrays travel as one float buffer (MPI
    Gatherv; a pickled gather of a frame of 10^5 elements took 7 ms on rank 0), their shapes pickled."""
    arrays = [a for s, values in local.values() for a in (s, values)] + ([] if cells is None else [cells])
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in arrays]
    flat = np.concatenate([a.ravel() for a in arrays]) if arrays else np.zeros(0)
    shapes = comm.gather([a.shape for a in arrays], root=0)
    counts = comm.gather(flat.size, root=0)
    recv = np.empty(sum(counts)) if comm.rank == 0 else None
    comm.Gatherv(flat, (recv, counts) if comm.rank == 0 else None, root=0)
    if comm.rank != 0:
        return None
    out, start = [], 0
    for rank_shapes, count in zip(shapes, counts):
        parts, at = [], start
        for shape in rank_shapes:
            size = int(np.prod(shape))
            parts.append(recv[at:at + size].reshape(shape))
            at += size
        start += count
        names = list(local)
        out.append(({n: (parts[2 * k], parts[2 * k + 1]) for k, n in enumerate(names)},
                    None if cells is None else parts[-1]))
    return out


class PlacedView(BodyView):
    """The view of a body of a System(distribute=True) built whole on another rank: its model (every
    rank has it) and the facts its rank sent; its states come through `body_views`' gather."""

    def __init__(self, name, model, facts):   # (no Body here: nothing of BodyView.__init__)
        self.name, self.body, self.model = name, None, model
        self._outputs = None
        for key, value in facts.items():
            setattr(self, key, value)

    def output_names(self):
        return self.outputs

    def gather(self):
        raise RuntimeError(f"body {self.name} is built on another rank: its state comes through body_views")


def body_views(problem):
    """(views of the bodies, gather): the output's views of every body in the order of
    problem.body_items(), on every rank, and a function returning their BodyStates on rank 0 (None
    elsewhere).  Collective.  For a System(distribute=True) each body is built whole on one rank: the
    views of the others' bodies are PlacedViews (their facts exchanged once), and every frame's states
    are sent to rank 0 by the ranks that own them."""
    local = [BodyView(name, body) for name, body in problem.body_items()]
    if not getattr(problem, "distributed", False):
        return local, lambda: [view.gather() for view in local]
    comm = problem.comm
    facts = {}
    for part in comm.allgather({view.name: view.facts() for view in local}):
        facts.update(part)
    own = {view.name: view for view in local}
    views = [own.get(name) or PlacedView(name, ref.body.model, facts[name]) for name, ref in problem.bodies.items()]

    def gather():
        states = {}
        for part in comm.gather({view.name: view.gather() for view in local}, root=0) or ():
            states.update(part)
        return [states[view.name] for view in views] if comm.rank == 0 else [None] * len(views)
    return views, gather


def blend(a, b, theta):
    """The BodyState (1 - theta) a + theta b of one body at two time levels (None on ranks other than 0):
    the state at t_n + theta h.  The midpoint rule (and the discrete gradient) move the configuration
    on a straight line over a step, q_{n+1} = q_n + h v_{n+1/2}: its positions and directors are on
    that line; the velocities and stresses are interpolated linearly too (second order, like the
    scheme).  The directors are orthonormal at the levels only (to O(h^2) between them)."""
    if a is None:
        return None
    mix = lambda x, y: None if x is None else (1 - theta) * x + theta * y   # noqa: E731
    return BodyState(a.name, a.kind, a.dim, a.s, mix(a.position, b.position),
                     {k: mix(v, b.fields[k]) for k, v in a.fields.items()}, mix(a.directors, b.directors),
                     {k: (v if k == "s" else mix(v, b.cells[k])) for k, v in a.cells.items()}, a.degree, a.box,
                     a.link)


def by_name(cells, names):
    """Split the gathered (cells, points, components) array into named fields, cells in order of s
    and the points of every cell in order of s."""
    flip = cells[:, 0, 0] > cells[:, -1, 0]       # a cell whose reference direction runs backwards
    cells[flip] = cells[flip, ::-1]
    cells = cells[np.argsort(cells[:, 0, 0], kind="stable")]
    out, k = {}, 0
    for name, size in names:
        out[name] = cells[:, :, k:k + size]
        k += size
    out["s"] = out["s"][:, :, 0]
    return out


def rows_of(state, a, b):
    """(part, lead): the nodes a, ..., b - 1 of a flexible body's BodyState and the cells their derived
    fields need (one more on each side: at a node between cells the mean of both), `lead` the place
    of node a among the nodes of those cells (frames.centreline(part, lead=lead))."""
    k, ncells = state.degree, len(state.cells["s"])
    ca, cb = max(a // k - 1, 0), min(ncells, (b - 1) // k + 2)
    part = BodyState(state.name, state.kind, state.dim, state.s[a:b], state.position[a:b],
                     {n: v[a:b] for n, v in state.fields.items()},
                     None if state.directors is None else state.directors[a:b],
                     {n: v[ca:cb] for n, v in state.cells.items()}, k)
    return part, a - ca * k


def at_nodes(values, degree):
    """Cell values (cells, 2k + 1, size) at the P_k nodes of the body (cells k + 1, size): exact inside a
    cell; at a node shared by two cells the mean of the two cells' values (a field that jumps there)."""
    nodes = values[:, ::2]                           # (cells, k + 1, size)
    ncells, k = len(values), degree
    out = np.empty((ncells * k + 1,) + values.shape[2:])
    out[:-1] = nodes[:, :-1].reshape((ncells * k,) + values.shape[2:])
    out[-1] = nodes[-1, -1]
    out[k:-1:k] = 0.5 * (nodes[1:, 0] + nodes[:-1, -1])
    return out


def at_midpoints(values):
    """Cell values (cells, 2k + 1, size) at the midpoints of the k segments of every cell,
    (cells k, size) in order of s: one value per segment between two nodes (exact there)."""
    mids = values[:, 1::2]
    return mids.reshape((-1,) + values.shape[2:])
