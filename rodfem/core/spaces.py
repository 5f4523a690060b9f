"""The state space: one mixed finite element space for x = (x_1, ..., x_n).

A model lists its fields (name, family, degree, shape); `StateSpace` builds
W_h = V_1 x ... x V_n on an interval mesh of [0, L] and hands out the UFL
components of a state function by field name.
"""
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem

from rodfem.errors import InputError
from rodfem.fem import compat


@dataclass(frozen=True)
class Field:
    """One component x_i of the state: `family` 'P' (C0) or 'DG', `shape` () or (d,)."""
    name: str
    family: str
    degree: int
    shape: tuple = ()

    @property
    def size(self):
        return int(np.prod(self.shape)) if self.shape else 1


def _dofmap_list(dofmap):
    """The cell-to-dof array of a dofmap, flattened."""
    return compat.dofmap_array(dofmap).reshape(-1)


def dofs_per_element(fields):
    """Dofs per element of a long mesh: P_k shares its end nodes (k per element), DG_k does not (k + 1)."""
    return sum((f.degree if f.family == "P" else f.degree + 1) * f.size for f in fields)


class StateSpace:
    """W_h = V_1 x ... x V_n for the fields of a model."""

    def __init__(self, mesh, fields):
        self.mesh = mesh
        self.fields = list(fields)
        self.index = {f.name: i for i, f in enumerate(self.fields)}
        els = [compat.element(f.family, mesh, f.degree, f.shape) for f in self.fields]
        self.V = compat.functionspace(mesh, compat.mixed_element(els))
        self._collapsed, self._scratch, self._nodes = {}, {}, {}

    @property
    def names(self):
        return [f.name for f in self.fields]

    def field(self, name):
        return self.fields[self.index[name]]

    def split(self, u):
        """The UFL components of u (a Function on W_h or a TestFunction) by name."""
        return dict(zip(self.names, ufl.split(u)))

    def sub(self, name):
        return self.V.sub(self.index[name])

    def collapse(self, name):
        """(V_i, dofs of V_i inside W_h), cached."""
        if name not in self._collapsed:
            self._collapsed[name] = self._collapse(name)
        return self._collapsed[name]

    def _collapse(self, name):
        """V_i made afresh from the field's element, its dofs inside W_h matched cell by cell.

        DOLFINx 0.5.2's collapse takes time quadratic in the mesh size for a blocked DG subspace
        (the strains: 11.5 s at 10^5 elements, most of a large run's set-up); this is linear.
        Collective (the element of V_i is JIT-compiled on first use, under the cache lock)."""
        from rodfem.fem.jit import locked
        f = self.field(name)
        with locked(self.mesh.comm):   # the element may be compiled (once per cache): under the cache lock
            Vi = compat.functionspace(self.mesh, compat.element(f.family, self.mesh, f.degree, f.shape))
        ncells = self.mesh.topology.index_map(self.mesh.topology.dim).size_local \
            + self.mesh.topology.index_map(self.mesh.topology.dim).num_ghosts
        sub = _dofmap_list(self.sub(name).dofmap).reshape(ncells, -1)
        bs = Vi.dofmap.bs
        blocks = _dofmap_list(Vi.dofmap).reshape(ncells, -1)
        unrolled = (blocks[:, :, None] * bs + np.arange(bs)).reshape(ncells, -1)
        if unrolled.shape != sub.shape:   # pragma: no cover - another DOLFINx layout
            return self.sub(name).collapse()
        dofs = np.empty((Vi.dofmap.index_map.size_local + Vi.dofmap.index_map.num_ghosts) * bs, dtype=np.int32)
        dofs[unrolled.ravel()] = sub.ravel()
        return Vi, dofs

    def assign(self, u, name, value):
        """Set component `name` of u by interpolation of `value`.

        `value` is a callable x -> array (x of shape (3, npoints), x[0] = s), a constant, a
        UFL expression (interpolated at the element's points) or one compiled (`expression`).
        """
        Vi, dofs = self.collapse(name)
        if name not in self._scratch:   # (a Function of V_i to interpolate into, one per field)
            self._scratch[name] = fem.Function(Vi)
        fi = self._scratch[name]
        if isinstance(value, ufl.core.expr.Expr):
            value = self.expression(name, value)
        elif not callable(value) and not isinstance(value, fem.Expression):
            value = self._constant(name, value)
        if isinstance(value, fem.Expression):
            compat.interpolate(fi, value)
        else:
            try:
                compat.interpolate(fi, value)
            except RuntimeError as e:  # DOLFINx names neither the field nor the shape it wanted
                want = f"({self.field(name).size}, npoints)" if self.field(name).shape else "(npoints,)"
                raise InputError(f"initial value of field '{name}': a function of x (shape (3, npoints)) "
                                 f"returning shape {want} is needed ({e})") from None
        u.x.array[dofs] = fi.x.array
        u.x.scatter_forward()

    def expression(self, name, value):
        """The UFL expression `value` compiled for interpolation into field `name` (a fem.Expression)."""
        if value.ufl_shape != tuple(self.field(name).shape):
            raise InputError(f"initial value of field '{name}': shape {value.ufl_shape}, "
                             f"the field has shape {tuple(self.field(name).shape)}")
        return fem.Expression(value, self.collapse(name)[0].element.interpolation_points())

    def _constant(self, name, value):
        """A constant initial value (a number, or an array of the field's shape) as a function of x."""
        shape = tuple(self.field(name).shape)
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            v = None
        if v is None or v.shape != shape or not np.all(np.isfinite(v)):
            raise InputError(f"initial value of field '{name}': a function of x, a UFL expression or a constant of "
                             f"shape {shape} is needed (got {value!r})")
        return lambda x: np.outer(v, np.ones(x.shape[1])) if shape else np.full(x.shape[1], float(v))

    def nodal(self, u, name):
        """Owned nodal values of component `name`: (s, values[npoints, size]), sorted by s."""
        if name not in self._nodes:   # (the nodes' s and where their values sit in u: once per field)
            Vi, dofs = self.collapse(name)
            bs = Vi.dofmap.index_map_bs
            nloc = Vi.dofmap.index_map.size_local
            s = Vi.tabulate_dof_coordinates()[:nloc, 0]
            order = np.argsort(s)
            self._nodes[name] = (s[order], np.asarray(dofs).reshape(-1, bs)[:nloc][order])
        s, at = self._nodes[name]
        return s.copy(), u.x.array[at]
