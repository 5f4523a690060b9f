# Shared pieces of the multibody scenes: a System that records extra history
# columns (momentum maps about a fixed pin, the frame of a rigid body), and
# the nodal fields of a body gathered on every rank.
import numpy as np
from dolfinx import fem
from mpi4py import MPI

from rodfem import compat
from rodfem.system import System

from forms.cosserat_rod import DIRECTORS


class RecordingSystem(System):
    """A System whose history has extra columns: each function in `columns` maps the
    system (state x_{n+1}) to a dict of numbers (collective: called on every rank)."""

    def __init__(self, *args, columns=(), **kwargs):
        super().__init__(*args, **kwargs)
        self.columns = list(columns)

    def observe(self):
        obs = super().observe()
        for column in self.columns:
            obs.update(column(self))
        return obs


def momentum_map(name):
    """A column function: the momentum map `name` ('L_z', 'p_x', ...) summed over all bodies, of x_{n+1}.

    (The System writes p and L only for a free system; a scene pinned at the
    origin can still record L about the origin, which the pin's reaction does not change.)"""
    cache = {}

    def column(system):
        if "forms" not in cache:
            cache["forms"] = []
            for ref in system.bodies.values():
                body = ref.body
                maps = body.momentum_forms(body.space.split(body.x1))
                if name in maps:
                    cache["forms"].append(compat.form(maps[name]))
        local = sum(fem.assemble_scalar(f) for f in cache["forms"])
        return {name: system.comm.allreduce(local, op=MPI.SUM)}
    return column


def nodal(body, field, state="x1"):
    """All nodal values of `field` of a body, sorted by s, on every rank: (s, values[n, size])."""
    s, vals = body.space.nodal(getattr(body, state), field)
    parts = body.comm.allgather((s, vals))
    s = np.concatenate([p[0] for p in parts])
    vals = np.concatenate([p[1] for p in parts])
    order = np.argsort(s, kind="stable")
    s, vals = s[order], vals[order]
    keep = np.concatenate([[True], np.diff(s) > 0]) if len(s) else []
    return s[keep], vals[keep]


def rigid_frame(body, state="x1"):
    """(x, R = [d1 d2 d3]) of a director-based rigid body (every rank)."""
    x = nodal(body, "x", state)[1][0]
    R = np.column_stack([nodal(body, d, state)[1][0] for d in DIRECTORS])
    return x, R


def orthonormality(body, state="x1"):
    """max |R^T R - I| over the nodes of a director-based body (rigid or rod), every rank."""
    R = np.stack([nodal(body, d, state)[1] for d in DIRECTORS], axis=2)
    return float(np.max(np.abs(np.einsum("nki,nkj->nij", R, R) - np.eye(3))))
