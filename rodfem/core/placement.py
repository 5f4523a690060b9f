"""Bodies placed whole on ranks: a system of many small bodies under `mpirun`.

By default every body's mesh is distributed over all ranks (a long rod gains from that).  A
system of many small bodies (a chain of links, a net of cables) gains instead from placing each
body whole on one rank (`System(distribute=True)`): the body is built on MPI.COMM_SELF of its
rank only (its mesh, spaces and forms: the build is shared out), the bodies of a rank are
assembled together (rodfem/fem/batch.py), and the global block system couples the ranks only
through the joints between bodies of different ranks (rodfem/fem/assembly.py's RankLayout:
each rank holds its bodies' dofs, then the multipliers of its joints).

The bodies are placed when the system is built, when their number is known: numbered k = 1..N
in the reverse Cuthill-McKee order of the graph of bodies and joints (joined bodies close), body k
of weight w_k (its number of elements, one for a rigid body) goes to the rank

    r_k = floor(R (w_1 + ... + w_{k-1} + w_k / 2) / (w_1 + ... + w_N))

(consecutive bodies on one rank, equal total weights; a joined chain crosses ranks R - 1
times, a net of n x n strings ~n times).  Until then a body is a `Placement` (its model and arguments); on the other ranks it
stays one.  The joints' points are computed on the rank of their body and shared
(`share_points`): every rank then knows their dofs and initial coordinates.
"""
import numpy as np
from mpi4py import MPI

from rodfem.errors import ConstraintError


def owners(weights, size, links=()):
    """The rank of each body: bodies consecutive in an order that keeps joined bodies together,
    balanced by weight, every rank at least one body (len(weights) >= size).

    The order: reverse Cuthill-McKee of the graph of the bodies and `links` (pairs of body indices:
    joints, springs, dampers), which numbers the bodies by levels of distance; cut into R parts, a
    chain is cut R - 1 times and a net of n x n strings along ~n of its crossings (in the order the
    strings were added, rows then columns, every crossing joined two ranks)."""
    w = np.asarray(weights, dtype=float)
    if len(w) < size:
        raise ValueError(f"{len(w)} bodies cannot be placed on {size} ranks")
    order = np.arange(len(w))
    links = np.asarray([(a, b) for a, b in links if a != b], dtype=np.int64).reshape(-1, 2)
    if len(links):
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import reverse_cuthill_mckee
        graph = coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(len(w), len(w))).tocsr()
        order = np.asarray(reverse_cuthill_mckee(graph + graph.T, symmetric_mode=True), dtype=np.int64)
    ws = w[order]
    mid = np.cumsum(ws) - 0.5 * ws
    ranked = np.minimum((size * mid / ws.sum()).astype(np.int64), size - 1)
    if len(np.unique(ranked)) < size:   # (very unequal weights left a rank empty: by count)
        ranked = (size * (np.arange(len(w)) + 0.5) / len(w)).astype(np.int64)
    rank = np.empty(len(w), dtype=np.int64)
    rank[order] = ranked
    return rank


class Placement:
    """A body before the system places it (and, on the other ranks, after): its model and the
    arguments of rodfem/core/body.py's Body, which `make` builds on this rank alone."""

    def __init__(self, model, length, n_elements, loads, supports, initial, integrator, name, contacts):
        self.model, self.name = model, name
        self.rigid = bool(getattr(model, "point", False))
        self.length, self.n_elements = float(length), 1 if self.rigid else n_elements
        self.loads, self.supports, self.initial = list(loads), list(supports), initial
        self.integrator, self.contacts = integrator, list(contacts)
        self.owner = None   # the rank it is built on (set by the system's build)
        self.bcs = []       # (none here: its conditions are on its rank)
        if self.contacts:
            raise ConstraintError(f"body {name}: a body with interactions (contacts) cannot be placed on one rank "
                                  "yet: use System(distribute=False)")
        if self.rigid and self.supports:
            raise ConstraintError(f"body {name or model}: a rigid body has no ends to support; fix it with a joint "
                                  "to GROUND")

    @property
    def weight(self):
        return 1 if self.rigid else max(int(self.n_elements), 1)

    def make(self, shared=None):
        """The Body on MPI.COMM_SELF (`shared`: the rank's rodfem/core/kinds.py Meshes, or None)."""
        from rodfem.core.body import Body
        return Body(self.model, self.length, self.n_elements, self.loads, self.supports, self.initial,
                    self.integrator, MPI.COMM_SELF, self.name, self.contacts, shared=shared)


def here(body) -> bool:
    """True for a body built on this rank (a Body), False for one placed on another (a Placement)."""
    return not isinstance(body, Placement)


def share_points(points, comm):
    """The PointCoordinates (rodfem/core/system.py) of every point, on every rank: computed on the
    rank of the point's body, then gathered (collective; `points`: the same list on every rank, the
    ground's left out).  Their dofs are local to the body on its rank (`body_index`: its place
    among the system's bodies, for rodfem/fem/assembly.py's `RankLayout.body_start`)."""
    from rodfem.core.system import PointCoordinates, point_coordinates
    mine, error = {}, None
    for k, p in enumerate(points):
        if here(p.body.body):
            try:
                pc = point_coordinates(p, MPI.COMM_SELF)
            except ConstraintError as err:   # (raised on every rank, below)
                error = error or str(err)
                continue
            mine[k] = (pc.q_dofs, pc.v_dofs, pc.layout, pc.values(0))
    found = {}
    for part, err in comm.allgather((mine, error)):
        if err:
            raise ConstraintError(err)
        found.update(part)
    out = []
    for k, p in enumerate(points):
        q_dofs, v_dofs, layout, q0 = found[k]
        pc = PointCoordinates(p, q_dofs, v_dofs, layout)
        pc._values[0] = q0
        out.append(pc)
    return out
