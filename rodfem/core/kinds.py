"""Bodies of one kind: one mesh, one state space and one compiled set of forms.

A system of many alike bodies (the links of a chain, the cables of a net) built each body's mesh,
state space, UFL forms and compiled forms afresh: 35 s for 1000 links, nearly all of it the same
work done again.  Here

* `Meshes` (one per system): bodies with the same number of cells and length share one interval
  mesh of [0, L] (with its end tags) and, for the same fields, one state space W_h.  Each body
  keeps its own Functions x_n, x_{n+1}, x(0), its step h and its loads' values.
* `kind(body)`: bodies of the same model object, length, integrator, supports and plain loads of
  the same shape (and no interactions) have forms equal up to the names of their Functions and
  Constants: the same UFL up to renaming, so the same compiled kernels.  The first body of a kind
  (its template) builds and compiles its forms; every other body gets the template's compiled
  forms with its own coefficients, constants, spaces and end tags (`twin_forms`): no UFL, no JIT.

A body's own objects are matched to the template's by their place (`counterparts`); every other
coefficient or constant of the template's forms must be the model's (reached from its
attributes: e.g. a material's parameters), shared by the kind, or the kind's bodies build their
forms one by one (`shareable`).
"""
from dolfinx import fem

from rodfem.core.ports import ENDS, Load


class Meshes:
    """The interval meshes and state spaces of a system's bodies, one per (cells, length) and fields."""

    def __init__(self):
        self._meshes, self._spaces, self._strains, self._elements = {}, {}, {}, {}

    def elements(self, n_elements, dofs_per_element, comm):
        """rodfem.common.limits.check_elements, once per number of cells (it reads the free memory)."""
        from rodfem.common.limits import check_elements
        key = (type(n_elements), n_elements, dofs_per_element)
        try:
            hash(key)
        except TypeError:
            return check_elements(n_elements, dofs_per_element, comm)
        if key not in self._elements:
            self._elements[key] = check_elements(n_elements, dofs_per_element, comm)
        return self._elements[key]

    def mesh(self, comm, n_elements, length):
        """(mesh of [0, length] with n_elements cells, its end vertices {'left', 'right'}, their tags)."""
        key = (int(n_elements), float(length))
        if key not in self._meshes:
            self._meshes[key] = interval(comm, n_elements, length)
        return self._meshes[key]

    def space(self, mesh, cls, fields):
        """The state space cls(mesh, fields) (one per mesh, class and fields)."""
        try:
            key = (id(mesh), cls, tuple(fields))
            hash(key)
        except TypeError:   # (fields that cannot be compared: a space of its own)
            return cls(mesh, fields)
        if key not in self._spaces:
            self._spaces[key] = (mesh, cls(mesh, fields))   # (the mesh kept: its id stays its own)
        return self._spaces[key][1]


    def strains(self, body, initial):
        """[(field, compiled expression on body.x0)] of the model's compatible strains not in `initial`:
        compiled for the first body of a model and space, the same
        kernels on their own x_n for the others (when the strains read nothing but x_n and the model's
        constants)."""
        from rodfem.fem import compat
        key = (id(body.model), id(body.space), frozenset(initial))
        if key in self._strains:
            x0, exprs = self._strains[key]
            swap = {id(x0): body.x0}
            return [(n, compat.expression_twin(e, swap, body.mesh)) for n, e in exprs]
        X0 = body.space.split(body.x0)
        import ufl
        values = [(n, e) for n, e in body.model.compatible_strains(X0).items() if n not in initial]
        if not all(isinstance(e, ufl.core.expr.Expr) for _, e in values):   # (callables, numbers: as they are)
            return values
        exprs = [(n, body.space.expression(n, e)) for n, e in values]
        model = _owned(body.model)
        if all({id(c) for c in ufl.algorithms.extract_coefficients(e._ufl_expression)} <= {id(body.x0)} and
               all(id(c) in model for c in ufl.algorithms.analysis.extract_constants(e._ufl_expression))
               for _, e in exprs):
            self._strains[key] = (body.x0, exprs)
        return exprs


def interval(comm, n_elements, length):
    """The mesh of [0, length], its end vertices and their tags (rodfem.core.ports.ENDS)."""
    import numpy as np
    from dolfinx import mesh as dmesh
    m = dmesh.create_interval(comm, n_elements, [0.0, length])
    tdim = m.topology.dim   # cell-to-cell: locate_dofs_topological on cells needs it (0.9)
    m.topology.create_connectivity(tdim, tdim)
    m.topology.create_connectivity(0, 1)
    facets = {"left": dmesh.locate_entities_boundary(m, 0, lambda x: np.isclose(x[0], 0.0)),
              "right": dmesh.locate_entities_boundary(m, 0, lambda x: np.isclose(x[0], length))}
    idx = np.concatenate([facets["left"], facets["right"]]).astype(np.int32)
    vals = np.concatenate([np.full(len(facets["left"]), ENDS["left"]),
                           np.full(len(facets["right"]), ENDS["right"])]).astype(np.int32)
    order = np.argsort(idx)
    return m, facets, dmesh.meshtags(m, 0, idx[order], vals[order])


def kind(body):
    """What decides the UFL of a body's forms besides its own objects (None: a body of its own kind)."""
    if body.contacts or any(type(load) is not Load for load in body.loads):
        return None
    loads = tuple((load.flow, load.where, load.pairing, tuple(load.constant.value.shape)) for load in body.loads)
    key = (id(body.model), type(body.space), tuple(body.space.fields), body.length, body.integrator, body.rigid,
           tuple(sorted((s.end, s.kind) for s in body.supports)), loads)
    try:
        hash(key)
    except TypeError:   # (fields or pairings that cannot be compared)
        return None
    return key


def counterparts(template, body):
    """id(template's object) -> body's: its states, step, loads' values, space and end tags."""
    pairs = [(template.x0, body.x0), (template.x1, body.x1), (template.state0, body.state0), (template.h, body.h),
             (template.space.V, body.space.V), (template.end_tags, body.end_tags)]
    pairs += [(a.constant, b.constant) for a, b in zip(template.loads, body.loads)]
    return {id(a): b for a, b in pairs}


def _owned(root, depth=6):
    """ids of the fem.Functions and fem.Constants reachable from `root`'s attributes, lists and dicts."""
    found, seen, todo = set(), set(), [(root, 0)]
    while todo:
        obj, d = todo.pop()
        if id(obj) in seen or d > depth:
            continue
        seen.add(id(obj))
        if isinstance(obj, (fem.Function, fem.Constant)):
            found.add(id(obj))
        elif isinstance(obj, dict):
            todo += [(v, d + 1) for v in obj.values()]
        elif isinstance(obj, (list, tuple, set)):
            todo += [(v, d + 1) for v in obj]
        elif hasattr(obj, "__dict__") and type(obj).__module__.split(".")[0] in ("rodfem", "forms"):
            todo += [(v, d + 1) for v in vars(obj).values()]
    return found


def shareable(template, forms):
    """Whether every coefficient and constant of the template's UFL forms is its own (`counterparts`)
    or its model's."""
    own = counterparts(template, template)
    model = _owned(template.model)
    for f in forms.values():
        if f is None:
            continue
        for c in list(f.coefficients()) + list(f.constants()):
            if id(c) not in own and id(c) not in model:
                return False
    return True


def twin_forms(template, body, forms, compiled):
    """The body's compiled forms: the template's (`compiled[key]` of the UFL `forms[key]`) on the
    body's objects."""
    from rodfem.fem import compat
    swap = counterparts(template, body)
    out = {}
    for key, f in forms.items():
        if f is None:
            out[key] = None
            continue
        out[key] = compat.form_twin(compiled[key], f, swap, body.mesh)
        out[key].rodfem_constants = [swap.get(id(c), c) for c in f.constants()]
    return out
