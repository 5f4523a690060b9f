"""Contact between bodies' centrelines (and of one body with itself), integrated energy-consistently.

`System.contact(law, a, b)` places a contact law (e.g. forms/rod_contact.py) between the flexible
bodies a and b (b None: self-contact of a).  The law gives, for segment pairs of the two centrelines
(the polylines through the nodes of the position field), their distance d (`closest_points`), the
reach R (the distance at which the tubes touch), the energy psi(d, R) and its difference quotient
z = [psi(d_{n+1}) - psi(d_n)] / (d_{n+1} - d_n) (`quotient`).

One of the two bodies may be rigid (a 3D rigid body: a sphere about its position): its position x is a
centreline of two nodes at the same place, [x, x], with the same global indices (`Centreline.point`),
so everything below holds for it unchanged: the pair's 4 nodes are x_i, x_{i+1}, x, x; the forces on
the two copies add up on x's rows and Newton's columns of both on x's columns (PETSc adds repeated
indices); the rigid projection treats x as a node (twice: the rigid motions move both copies alike,
so P dX is the same on both and D . dX = d_{n+1} - d_n still holds with the work z D . dX done on x
once per copy).  The rigid body's rotation gets no force: the sphere's contact acts through its centre.

The step's force on the 4 nodes X = (x_i, x_{i+1}, y_j, y_{j+1}) of a segment pair is z D, with D a
discrete gradient of the distance that also keeps the momenta:

    D = grad d(X_m) + [d(X_{n+1}) - d(X_n) - grad d(X_m) . dX] P dX / |P dX|^2,   dX = X_{n+1} - X_n,

P the orthogonal projector onto the complement of the rigid motions at the midpoint X_m (the six
vectors (e_k, e_k, e_k, e_k) and (e_k x x_m,node)).  Then D . dX = d_{n+1} - d_n exactly (Gonzalez,
"Time integration and discrete Hamiltonian systems", J Nonlinear Sci 6 (1996) 449-467, DOI
10.1007/BF02440162: the midpoint discrete gradient, here with the correction restricted to what
keeps the invariants, as in McLachlan, Quispel & Robidoux, "Geometric integration using discrete
gradients", Phil Trans R Soc A 357 (1999) 1021-1045, DOI 10.1098/rsta.1999.0363), so with the
kinematic rows x_{n+1} - x_n = h v_m at the nodes the force does the work z (d_{n+1} - d_n) =
psi_{n+1} - psi_n: the pair's energy joins H and the balance holds to round-off.  grad d(X_m) is
orthogonal to the rigid motions (d is invariant), and so is P dX: the forces sum to zero and have no
moment about the origin at the midpoint positions, so the linear and angular momentum of the bodies
are conserved exactly by the contact (the rods' own discretization conserves them).  Where
|P dX| <= 1e-6 R (a step that moves the pair rigidly, or not at all) the correction is dropped
(D = grad d(X_m)): its size there is O(|P dX| |dX|^2), far below round-off of the balance.

Active set: every Newton iterate recomputes the segment pairs (no active set is kept): the broad
phase finds the pairs whose bounding spheres -- about the segment's nodes at x_n AND at the iterate
x_{n+1}, grown by the tube radius -- overlap (scipy's cKDTree on the spheres' centres: O(n log n),
not O(n^2)), and every pair they contain that is in contact at x_n, x_m or x_{n+1} contributes.
So the residual is one function of x_{n+1}: the sum over ALL segment pairs (the others contribute
exactly zero, their spheres being apart), and a contact that starts or ends within a step is in the
difference quotient.  Newton's matrix is dF/dx_{n+1} of each contributing pair by central
differences.

Friction (a law with a `friction`, forms/rod_contact.py): the friction force f of each pair in contact
(the law's Coulomb `factor` times the slip v_t of the closest points at the midpoint) acts as f on body
a's closest point and -f on body b's, shared by the nodes as the normal force is; its work
h f . v_t <= 0 is the step's `dissipated`.  It needs the nodes' velocities (gathered with the
positions) and h (`step(X0, h)`); Newton's matrix gets its derivatives in x_{n+1} and v_{n+1} (central
differences).  Not in statics (at rest nothing slips).

Newton's matrix pattern: the entries of the CANDIDATE pairs (the broad phase's, a superset of the
pairs in contact) are added to the matrix's pattern in one re-preallocation when pairs appear that it
does not hold yet (`grow`, called by the assembler before it zeroes the matrix), instead of PETSc
reallocating the whole matrix for every new nonzero; the pattern is kept (and reused) afterwards.  The
pairs' 12 x 12 blocks are added one call each, the supported rows and columns as PETSc's ignored
index -1.

Under MPI the nodes of the bodies in contact are gathered on rank 0 (one scatter of the position
dofs; rods are long and thin, so this is n_nodes x 3 numbers), which computes the pairs and adds
their forces to the global rows; the energy and the columns are broadcast.

The rows of supported (Dirichlet) nodes are left alone: their reaction takes the force.

No passing through within a step (`crossing`): the penalty acts only where a pair is in contact at x_n,
x_m or x_{n+1}, so a step that moves two segments across each other can cross them (a step that takes
them from one side to the other with neither end in contact feels no force at all).  Along the straight
path X(tau) = X_n + tau dX, tau in [0, 1], the points of the two segments move relatively by at most
s = max over node pairs (i of a, j of b) |dx_i - dy_j| (the relative motion of two points is a convex
combination of these), so their distance d(tau) >= max(d_n - tau s, d_{n+1} - (1 - tau) s), and

    min over tau of d(tau) >= c = (d_n + d_{n+1} - s) / 2      (the pair's certified clearance).

c > 0 proves that the step did not pass the two segments through each other (c = 0 exactly for a
head-on pass through d = 0, so the test needs a margin); a step is accepted when every candidate pair
(the broad phase's spheres over x_n and x_{n+1}: the pairs whose swept segments can meet at all) has
c >= CLEARANCE R, i.e. along the whole path the tubes overlap by less than half the reach R: the
penalty acted at every stage of an approach, and no pair was carried deep into (or through) the other.
A step where a pair does not is refused (`System.solve` raises a NewtonFailure, so the time loop retries
it from x_n and then splits it into sub-steps, rodfem/analysis/stepping.py).  The test is sufficient,
not necessary: it may refuse a step that did not cross (a pair in contact sliding by more than about
R in one step), never accept one that did.  A refused step is not part of the solution, so the energy
balance of the accepted (sub-)steps is untouched.
"""
import time

import numpy as np
from petsc4py import PETSc
from scipy.spatial import cKDTree

from rodfem.errors import ConstraintError

FD_STEP = 1e-7      # Newton's matrix: central differences with steps FD_STEP R
RIGID_BELOW = 1e-6  # |P dX| <= RIGID_BELOW R: no correction (see the module docstring)
CLEARANCE = 0.5     # a step is accepted when each pair's certified clearance is >= CLEARANCE R (the docstring)


def close_pairs(centres, radii, others=None, other_radii=None):
    """All pairs (i, j), i < j, of spheres (centres (n, 3), radii (n,)) that overlap: |c_i - c_j| <= r_i + r_j
    (cKDTree.query_pairs within 2 max r, then the exact test); with `others` (and their radii), the
    pairs (i of centres, j of others) that overlap (two trees: no pair within one set is visited).
    Returns an array (m, 2)."""
    none = np.zeros((0, 2), dtype=np.int64)
    if others is not None:
        if not len(centres) or not len(others):
            return none
        reach = float(np.max(radii)) + float(np.max(other_radii))
        pairs = cKDTree(centres).sparse_distance_matrix(cKDTree(others), reach, output_type="ndarray")
        keep = pairs["v"] <= radii[pairs["i"]] + other_radii[pairs["j"]]
        return np.column_stack([pairs["i"][keep], pairs["j"][keep]]).astype(np.int64)
    if len(centres) < 2:
        return none
    tree = cKDTree(centres)
    pairs = tree.query_pairs(2.0 * float(np.max(radii)), output_type="ndarray")
    if len(pairs):
        gap = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1)
        pairs = pairs[gap <= radii[pairs[:, 0]] + radii[pairs[:, 1]]]
    return pairs.astype(np.int64)


def segment_spheres(*positions, grow=0.0):
    """Bounding spheres of the segments (i, i+1) of node positions (each (n, 3)) over all the given
    configurations, grown by `grow` (a number or an array per segment): (centres, radii)."""
    pts = np.concatenate([np.stack([x[:-1], x[1:]], axis=1) for x in positions], axis=1)   # (n-1, 2k, 3)
    c = pts.mean(axis=1)
    r = np.max(np.linalg.norm(pts - c[:, None, :], axis=2), axis=1)
    return c, r + grow


def rigid_projection(dX, Xm):
    """P dX for the configurations Xm (n, m, 3) and increments dX (n, m, 3): dX less its part in the
    span of the rigid motions at Xm, the translation t + rotation w x (x - c) about the nodes' centroid c
    (orthogonal projection: t = the mean of dX, J w = sum (x - c) x dX with J = sum |x - c|^2 I - (x - c)(x - c)^T,
    regularized by 1e-14 tr J: nodes on a line have no rotation about it, and neither has dX's part)."""
    rel = Xm - Xm.mean(axis=1, keepdims=True)
    r2 = np.einsum("nij,nij->n", rel, rel)
    J = r2[:, None, None] * np.eye(3) - np.einsum("nia,nib->nab", rel, rel) + 1e-14 * r2[:, None, None] * np.eye(3)
    w = np.linalg.solve(J, np.cross(rel, dX).sum(axis=1)[:, :, None])[:, :, 0]
    return dX - dX.mean(axis=1, keepdims=True) - np.cross(w[:, None, :], rel)


class Centreline:
    """A flexible body's centreline nodes: the global indices of their positions q and velocities v
    (n_nodes x 3 each) and arc lengths s, sorted along the body (on every rank)."""

    point = False   # a rigid body's centre: two nodes at the same place (a segment of zero length)

    def __init__(self, ref, layout, i):
        body = ref.body
        model = body.model
        position = getattr(model, "position", None)
        velocity = getattr(model, "kinematics", {}).get(position)
        if body.rigid:
            return self._centre(ref, layout, i, position, velocity)
        if velocity is None or tuple(body.space.field(position).shape) != (3,):
            raise ConstraintError(f"contact with body {ref.name}: it must be a 3D rod or string (a centreline "
                                  "of 3 coordinates) or a 3D rigid body; planar bodies are not supported")
        if body.space.field(position).family != "P" or body.space.field(velocity).family != "P":
            raise ConstraintError(f"contact with body {ref.name}: its position must be a continuous (P) field")
        l2g = layout.local_to_global(i)
        own = layout.sizes[i]
        tables = []
        for name in (position, velocity):
            Vi, dofs = body.space.collapse(name)
            dofs = dofs.reshape(-1, 3)
            s = Vi.tabulate_dof_coordinates()[: len(dofs), 0]
            owned = np.all(dofs < own, axis=1)
            tables.append((s[owned], l2g[dofs[owned]]))
        comm = layout.comm
        (s, q), (sv, v) = ([np.concatenate(a) for a in zip(*comm.allgather(t))] for t in tables)
        s, keep = np.unique(np.round(s, 12), return_index=True)
        q = q[keep]
        sv, keep_v = np.unique(np.round(sv, 12), return_index=True)
        if len(sv) != len(s) or not np.allclose(sv, s):   # pragma: no cover - the same element for both
            raise ConstraintError(f"contact with body {ref.name}: its position and velocity nodes differ")
        self.name, self.s, self.q, self.v = ref.name, s, q, v[keep_v]

    def _centre(self, ref, layout, i, position, velocity):
        """A rigid body's position x (its sphere's centre) as the segment of zero length [x, x]: both nodes
        have the same global indices, so the pair's forces on them add up on x's rows (and Newton's matrix
        entries on its columns)."""
        check_centre(ref.body, ref.name, position, velocity)
        own = layout.sizes[i]
        l2g = layout.local_to_global(i)
        found = []
        for name in (position, velocity):
            dofs = np.asarray(ref.body.space.field_dofs(name), dtype=np.int64)
            found.append(l2g[dofs] if len(dofs) and np.all(dofs < own) else np.zeros(0, np.int64))
        q, v = (np.concatenate(layout.comm.allgather(f)) for f in found)
        self.point = True
        self.name, self.s = ref.name, np.zeros(2)
        self.q, self.v = np.stack([q, q]), np.stack([v, v])


def check_centre(body, name, position, velocity):
    """Refuse a rigid body without a 3D position field (and its velocity) to carry a sphere."""
    if position is None or velocity is None or tuple(body.space.field(position).shape) != (3,):
        raise ConstraintError(f"contact with rigid body {name}: its model needs a position field of 3 coordinates "
                              "(`position`, with its velocity in `kinematics`) for the sphere's centre")


class Pairing:
    """One contact law between two centrelines (b None: one centreline with itself)."""

    def __init__(self, law, a, b, name):
        self.law, self.a, self.b, self.name = law, a, b, name
        self.self_contact = b is None
        self.R = float(law.reach(self.self_contact))

    def candidates(self, nodes_a, nodes_b, configurations):
        """Segment pairs (i of a, j of b) whose spheres over `configurations` (indices into the node
        arrays' list) overlap."""
        ra, rb = self.law.radii if not self.self_contact else (self.law.radii[0],) * 2
        ca, rad_a = segment_spheres(*[nodes_a[k] for k in configurations], grow=ra)
        if self.self_contact:
            pairs = close_pairs(ca, rad_a)
            s = self.a.s
            sep = s[pairs[:, 1]] - s[pairs[:, 0] + 1]   # arc length between the segments (i < j)
            return pairs[(sep >= self.law.exclude) & (pairs[:, 1] > pairs[:, 0] + 1)]
        cb, rad_b = segment_spheres(*[nodes_b[k] for k in configurations], grow=rb)
        pairs = close_pairs(ca, rad_a, cb, rad_b)
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

    def stack(self, nodes_a, nodes_b, pairs):
        """The pairs' node positions (m, 4, 3): x_i, x_{i+1}, y_j, y_{j+1}."""
        nb = nodes_a if self.self_contact else nodes_b
        i, j = pairs[:, 0], pairs[:, 1]
        return np.stack([nodes_a[i], nodes_a[i + 1], nb[j], nb[j + 1]], axis=1)

    def weights(self, pairs):
        """The pairs' weights min(1, l_i / zone) min(1, l_j / zone) (l: the segments' lengths along the rods
        at rest; 1 for every pair without a zone): segments shorter than the contact zone share it."""
        zone = float(getattr(self.law, "zone", 0.0))
        if zone <= 0.0 or not len(pairs):
            return np.ones(len(pairs))
        la = np.diff(self.a.s)[pairs[:, 0]]
        lb = np.diff((self.a if self.self_contact else self.b).s)[pairs[:, 1]]
        wa = 1.0 if getattr(self.a, "point", False) else np.minimum(1.0, la / zone)   # (a sphere's centre: weight 1)
        wb = 1.0 if not self.self_contact and getattr(self.b, "point", False) else np.minimum(1.0, lb / zone)
        return wa * wb * np.ones(len(pairs))

    def indices(self, pairs, which):
        """Global indices (m, 4, 3) of the pairs' nodes' q or v dofs."""
        A = getattr(self.a, which)
        B = A if self.self_contact else getattr(self.b, which)
        i, j = pairs[:, 0], pairs[:, 1]
        return np.stack([A[i], A[i + 1], B[j], B[j + 1]], axis=1)

    def distance(self, X):
        d, a, b, n = self.law_points(X)
        return d

    def law_points(self, X):
        """The law's closest points (d, a, b, n) of the pairs' segments X (m, 4, 3)."""
        return self.law.closest_points(X[:, 0], X[:, 1], X[:, 2], X[:, 3])

    def gradient(self, X):
        """(d, grad d (m, 4, 3)) at X by the envelope theorem."""
        d, a, b, n = self.law_points(X)
        w = np.stack([1.0 - a, a, b - 1.0, -b], axis=1)
        return d, w[:, :, None] * n[:, None, :]

    def force(self, X0, X1, rule="discrete-gradient"):
        """z D (m, 4, 3): the step's force on the pairs' nodes (the module docstring); the midpoint rule's
        psi'(d(X_m)) grad d(X_m) with rule 'midpoint'."""
        Xm = 0.5 * (X0 + X1)
        if rule == "midpoint":
            d, grad = self.gradient(Xm)
            return self.law.slope(d, self.R)[:, None, None] * grad
        d0, d1 = self.distance(X0), self.distance(X1)
        _, grad = self.gradient(Xm)
        dX = X1 - X0
        P = rigid_projection(dX, Xm)
        nP2 = np.einsum("nij,nij->n", P, P)
        bracket = (d1 - d0) - np.einsum("nij,nij->n", grad, dX)
        use = nP2 > (RIGID_BELOW * self.R) ** 2
        c = np.where(use, bracket / np.where(use, nP2, 1.0), 0.0)
        D = grad + c[:, None, None] * P
        z = self.law.quotient(d0, d1, self.R)
        return z[:, None, None] * D

    def normal_effort(self, X0, X1, rule="discrete-gradient"):
        """z of the step: the penalty's difference quotient in the distance (psi'(d(X_m)) with rule 'midpoint')."""
        if rule == "midpoint":
            return self.law.slope(self.distance(0.5 * (X0 + X1)), self.R)
        return self.law.quotient(self.distance(X0), self.distance(X1), self.R)

    def friction(self, X0, X1, V0, V1, w, rule="discrete-gradient"):
        """(F, power): the friction forces on the pairs' nodes (m, 4, 3) and their power f . v_t <= 0 (m,) of the
        step (forms/rod_contact.py): f = factor(N, |v_t|^2) v_t on body a's closest point, -f on body b's, with
        the closest points' parameters and normal at X_m, the slip of the midpoint velocities and N = -w z."""
        a, b, n = self.law_points(0.5 * (X0 + X1))[1:]
        share = np.stack([1.0 - a, a, b - 1.0, -b], axis=1)                   # (m, 4): a's nodes +, b's -
        rel = np.einsum("nk,nkj->nj", share, 0.5 * (V0 + V1))                  # v_a(a) - v_b(b) at the midpoint
        vt = rel - np.einsum("nj,nj->n", rel, n)[:, None] * n
        N = np.maximum(-w * self.normal_effort(X0, X1, rule), 0.0)
        f = self.law.friction.factor(N, np.einsum("nj,nj->n", vt, vt))[:, None] * vt
        return share[:, :, None] * f[:, None, :], np.einsum("nj,nj->n", f, vt)

    def friction_jacobian(self, X0, X1, V0, V1, w, rule="discrete-gradient"):
        """(dF/dX1, dF/dV1), each (m, 12, 12) [pair, row, column], of `friction` by central differences."""
        m = len(X0)
        out = []
        for k, step in ((1, FD_STEP * max(self.R, 1e-12)), (3, FD_STEP * max(float(np.max(np.abs(V1), initial=0.0)), 1e-8))):
            E = np.eye(12).reshape(12, 4, 3) * step
            args = [np.repeat(A, 12, axis=0) for A in (X0, X1, V0, V1)]
            plus, minus = list(args), list(args)
            plus[k] = (args[k].reshape(m, 12, 4, 3) + E[None]).reshape(-1, 4, 3)
            minus[k] = (args[k].reshape(m, 12, 4, 3) - E[None]).reshape(-1, 4, 3)
            wr = np.repeat(w, 12)
            diff = (self.friction(*plus, wr, rule)[0] - self.friction(*minus, wr, rule)[0]).reshape(m, 12, 12) / (2 * step)
            out.append(np.transpose(diff, (0, 2, 1)))
        return out

    def jacobian(self, X0, X1, rest=False, rule="discrete-gradient"):
        """d(z D)/dX1 (m, 12, 12) by central differences (`rest`: X0 = X1 moves too, the Hessian of V)."""
        m = len(X0)
        step = FD_STEP * max(self.R, 1e-12)
        E = np.eye(12).reshape(12, 4, 3) * step
        plus = (X1[:, None] + E[None]).reshape(-1, 4, 3)
        minus = (X1[:, None] - E[None]).reshape(-1, 4, 3)
        if rest:
            diff = (self.force(plus, plus, rule) - self.force(minus, minus, rule)).reshape(m, 12, 12) / (2 * step)
            return np.transpose(diff, (0, 2, 1))
        base = np.repeat(X0, 12, axis=0)
        diff = (self.force(base, plus, rule) - self.force(base, minus, rule)).reshape(m, 12, 12) / (2 * step)
        return np.transpose(diff, (0, 2, 1))    # [pair, row (force component), column (coordinate)]


class BodyContacts:
    """The contact laws placed by `System.contact`, as a coupling of rodfem/fem/assembly.py (forces on the
    momentum rows at global indices, computed on rank 0); `step`, `energy`, `observe` for the system."""

    def __init__(self, items, refs, layout, fixed, X, rule="discrete-gradient", rest=False):
        """rule: the system's integrator ('midpoint': the force psi'(d(X_m)) grad d(X_m), not energy-consistent);
        rest: statics (rodfem/analysis/statics.py) -- the force grad V(x) of the iterate, x_n = x_{n+1}."""
        self.comm, self.fixed, self.rule, self.rest = layout.comm, fixed, rule, rest
        index = {id(r): k for k, r in enumerate(refs)}
        lines = {}
        for law, a, b, name in items:
            for ref in (a, b):
                if ref is not None and id(ref) not in lines:
                    lines[id(ref)] = Centreline(ref, layout, index[id(ref)])
        self.lines = list(lines.values())
        self.pairings = [Pairing(law, lines[id(a)], None if b is None else lines[id(b)], name)
                         for law, a, b, name in items]
        self.rubs = not rest and any(getattr(p.law, "friction", None) is not None for p in self.pairings)
        kinds = ("q", "v") if self.rubs else ("q",)
        wanted = np.concatenate([getattr(ln, kind).ravel() for kind in kinds for ln in self.lines]).astype(PETSc.IntType)
        self.at, k = [], 0
        for ln in self.lines:
            self.at.append((k, len(ln.s)))
            k += 3 * len(ln.s)
        self.v_at = k   # where the velocities start in the gathered vector
        root = self.comm.rank == 0
        self.gathered = PETSc.Vec().createSeq(len(wanted) if root else 0, comm=PETSc.COMM_SELF)
        is_from = PETSc.IS().createGeneral(wanted if root else np.zeros(0, PETSc.IntType), comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(X, is_from, self.gathered, None)
        self.x0 = self.v0 = None
        self.h = 0.0
        self._terms = []
        self._known = [set() for _ in self.pairings]   # the pairs (keys) whose entries the matrix's pattern holds
        self._fresh = [np.zeros(0, np.int64) for _ in self.pairings]   # candidate pairs' keys of the last iterate
        self.fixed_index = np.array(sorted(fixed), dtype=np.int64)
        self.work = self.dissipated = 0.0
        self.seconds = {"search": 0.0, "forces": 0.0, "matrix": 0.0}   # rank 0's CPU time in the contact (benchmarks)

    def gather(self, X):
        """({id(line): node positions (n, 3)}, {id(line): node velocities} (None without friction)) of the
        state X (rank 0; None elsewhere)."""
        self.scatter.scatter(X, self.gathered, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self.comm.rank != 0:
            return None, None
        vals = self.gathered.getArray(readonly=True)
        x = {id(ln): vals[k:k + 3 * n].reshape(n, 3).copy() for ln, (k, n) in zip(self.lines, self.at)}
        v = ({id(ln): vals[self.v_at + k:self.v_at + k + 3 * n].reshape(n, 3).copy() for ln, (k, n) in zip(self.lines, self.at)}
             if self.rubs else None)
        return x, v

    def nodes(self, X):
        """{id(line): node positions (n, 3)} of the state X (rank 0; None elsewhere)."""
        return self.gather(X)[0]

    def step(self, X0, h=0.0):
        """The step of size h from x_n = X0 (collective)."""
        self.x0, self.v0 = self.gather(X0)
        self.h = float(h)

    # -- the coupling's contract (rodfem/fem/assembly.py) -----------------------------------------
    def entries(self):
        return []   # the pairs' entries join the pattern when they appear (`grow`)

    def grow(self):
        """The (rows, cols) entries of the candidate pairs of the last iterate that the matrix's pattern does
        not hold yet (rank 0; the others: []), or None if there are none on any rank (collective)."""
        out = []
        if self.comm.rank == 0:
            for k, p in enumerate(self.pairings):
                keys = self._fresh[k]
                new = keys[[int(key) not in self._known[k] for key in keys]] if len(keys) else keys
                if not len(new):
                    continue
                self._known[k].update(new.tolist())
                nb = len((p.a if p.self_contact else p.b).s)
                pairs = np.column_stack(np.divmod(new, nb))
                rows = p.indices(pairs, "v").reshape(-1, 12)
                for kind in ("q", "v") if getattr(p.law, "friction", None) is not None and self.rubs else ("q",):
                    cols = p.indices(pairs, kind).reshape(-1, 12)
                    out.append((np.repeat(rows, 12, axis=1).ravel(), np.tile(cols, (1, 12)).ravel()))
        grown = self.comm.bcast(bool(out), root=0)
        return out if grown else None

    def _active(self, p, x0, x1):
        """The candidate pairs of pairing p (the broad phase's) and those in contact at x_n, x_m or x_{n+1}:
        (candidates, pairs, X0, X1, weights)."""
        a, b = id(p.a), None if p.self_contact else id(p.b)
        nodes = [(x0[a], x1[a], 0.5 * (x0[a] + x1[a])), None if b is None else (x0[b], x1[b], 0.5 * (x0[b] + x1[b]))]
        pairs = p.candidates(nodes[0], nodes[1], (0, 1))
        X0 = p.stack(x0[a], None if b is None else x0[b], pairs)
        X1 = p.stack(x1[a], None if b is None else x1[b], pairs)
        near = np.minimum.reduce([p.distance(X) for X in (X0, X1, 0.5 * (X0 + X1))]) < p.R if len(pairs) else []
        return pairs, pairs[near], X0[near], X1[near], p.weights(pairs[near])

    def update(self, X):
        start = time.process_time()
        x1, v1 = self.gather(X)
        if self.rest:
            self.x0 = x1
        self._terms = []
        if self.comm.rank == 0:
            for k, p in enumerate(self.pairings):
                candidates, pairs, X0, X1, w = self._active(p, self.x0, x1)
                self._fresh[k] = candidates[:, 0] * len((p.a if p.self_contact else p.b).s) + candidates[:, 1]
                if not len(pairs):
                    continue
                rubs = self.rubs and getattr(p.law, "friction", None) is not None
                V = (p.stack(self.v0[id(p.a)], None if p.self_contact else self.v0[id(p.b)], pairs),
                     p.stack(v1[id(p.a)], None if p.self_contact else v1[id(p.b)], pairs)) if rubs else None
                self._terms.append((p, pairs, X0, X1, w, V))
        self.seconds["search"] += time.process_time() - start

    def crossing(self, X):
        """The smallest certified clearance of the step x_n -> X (module docstring) over the pairings'
        candidate pairs: (c / R, name, pair), c = (d_n + d_{n+1} - s) / 2 (> 0: no pair can have crossed;
        inf without candidates), collective (the same on every rank)."""
        x1 = self.nodes(X)
        worst = (np.inf, "", (-1, -1))
        if self.comm.rank == 0:
            for p in self.pairings:
                a, b = id(p.a), None if p.self_contact else id(p.b)
                pairs = p.candidates((self.x0[a], x1[a]), None if b is None else (self.x0[b], x1[b]), (0, 1))
                if not len(pairs):
                    continue
                X0 = p.stack(self.x0[a], None if b is None else self.x0[b], pairs)
                X1 = p.stack(x1[a], None if b is None else x1[b], pairs)
                dX = X1 - X0
                rel = dX[:, :2, None, :] - dX[:, None, 2:, :]            # dx_i - dy_j (m, 2, 2, 3)
                s = np.sqrt(np.einsum("mijk,mijk->mij", rel, rel)).max(axis=(1, 2))
                margin = 0.5 * (p.distance(X0) + p.distance(X1) - s) / max(p.R, 1e-300)
                k = int(np.argmin(margin))
                if margin[k] < worst[0]:
                    worst = (float(margin[k]), p.name, tuple(int(i) for i in pairs[k]))
        return self.comm.bcast(worst, root=0)

    def _free(self, index):
        """The global indices `index` with the supported ones replaced by -1 (PETSc ignores those)."""
        index = np.asarray(index, dtype=np.int64)
        if len(self.fixed_index):
            index = np.where(np.isin(index, self.fixed_index), -1, index)
        return index.astype(PETSc.IntType)

    def residual(self, X, b):
        start = time.process_time()
        lost = 0.0
        for p, pairs, X0, X1, w, V in self._terms:
            vals = w[:, None, None] * p.force(X0, X1, self.rule)
            if V is not None:   # friction: the force on the node is minus the residual's term
                F, power = p.friction(X0, X1, *V, w, self.rule)
                vals = vals - F
                lost -= self.h * float(np.sum(power))
            rows = self._free(p.indices(pairs, "v").ravel())
            own = rows >= 0          # (a Vec does not ignore the index -1 as a Mat does: the supported rows out)
            b.setValues(rows[own], np.ascontiguousarray(vals.ravel()[own]), addv=PETSc.InsertMode.ADD)
        self.dissipated = self.comm.bcast(lost, root=0)
        self.seconds["forces"] += time.process_time() - start

    def jacobian(self, X, A):
        start = time.process_time()
        for p, pairs, X0, X1, w, V in self._terms:
            rows = self._free(p.indices(pairs, "v").reshape(-1, 12))
            blocks = w[:, None, None] * p.jacobian(X0, X1, self.rest, self.rule)
            parts = [(self._free(p.indices(pairs, "q").reshape(-1, 12)), blocks)]
            if V is not None:
                dq, dv = p.friction_jacobian(X0, X1, *V, w, self.rule)
                parts[0] = (parts[0][0], parts[0][1] - dq)
                parts.append((self._free(p.indices(pairs, "v").reshape(-1, 12)), -dv))
            for cols, blocks in parts:
                for r, c, block in zip(rows, cols, np.ascontiguousarray(blocks)):
                    A.setValues(r, c, block, addv=PETSc.InsertMode.ADD)
        self.seconds["matrix"] += time.process_time() - start

    def _friction_columns(self, p):
        """name.Ft_x, _y, _z: the friction force on body a (zero for self-contact), and name.Mf_x, _y, _z: the
        moment sum (x_c - y_c)_m x f of the pairs' force couples (module docstring of forms/rod_contact.py),
        of the last step (its last Newton iterate)."""
        Ft, Mf = np.zeros(3), np.zeros(3)
        for q, pairs, X0, X1, w, V in self._terms:
            if q is not p or V is None:
                continue
            F, _ = p.friction(X0, X1, *V, w, self.rule)
            Xm = 0.5 * (X0 + X1)
            if not p.self_contact:
                Ft += (F[:, 0] + F[:, 1]).sum(axis=0)
            Mf += np.cross(Xm, F).sum(axis=(0, 1))
        out = {f"{p.name}.Ft_{c}": float(v) for c, v in zip("xyz", Ft)}
        out.update({f"{p.name}.Mf_{c}": float(v) for c, v in zip("xyz", Mf)})
        return out

    # -- the system's view ------------------------------------------------------------------------
    def _state(self, X):
        """Per pairing: (pairs, d, grad d, weights) of the segment pairs in contact at the state X (rank 0)."""
        x = self.nodes(X)
        out = []
        if self.comm.rank == 0:
            for p in self.pairings:
                a, b = id(p.a), None if p.self_contact else id(p.b)
                pairs = p.candidates((x[a],), None if b is None else (x[b],), (0,))
                Xs = p.stack(x[a], None if b is None else x[b], pairs)
                d, grad = p.gradient(Xs) if len(pairs) else (np.zeros(0), np.zeros((0, 4, 3)))
                near = d < p.R
                out.append((pairs[near], d[near], grad[near], p.weights(pairs[near])))
        return out

    def energy(self, X) -> float:
        """The contacts' stored energy at the state X (collective, the same on every rank)."""
        states = self._state(X)
        V = sum(float(np.sum(w * p.law.energy(d, p.R))) for p, (_, d, _, w) in zip(self.pairings, states)) \
            if self.comm.rank == 0 else 0.0
        return self.comm.bcast(V, root=0)

    def observe(self, X) -> dict:
        """name.energy, name.N (the sum of the pairs' normal forces -psi'), name.Fn_x, _y, _z (the contact
        force on body a; zero for self-contact), name.penetration (the largest <R - d>), name.active (the
        number of segment pairs in contact) of the state X (collective); the pairs weighted as in V."""
        states = self._state(X)
        obs = {}
        if self.comm.rank == 0:
            for p, (pairs, d, grad, w) in zip(self.pairings, states):
                slope = w * p.law.slope(d, p.R)
                on_a = -np.einsum("n,nk->k", slope, grad[:, 0] + grad[:, 1]) if not p.self_contact else np.zeros(3)
                obs[f"{p.name}.energy"] = float(np.sum(w * p.law.energy(d, p.R)))
                obs[f"{p.name}.N"] = float(-np.sum(slope))
                for c, f in zip("xyz", on_a):
                    obs[f"{p.name}.Fn_{c}"] = float(f)
                obs[f"{p.name}.penetration"] = float(np.max(p.R - d, initial=0.0))
                obs[f"{p.name}.active"] = float(len(pairs))
                if self.rubs and getattr(p.law, "friction", None) is not None:
                    obs.update(self._friction_columns(p))
        return self.comm.bcast(obs, root=0)


def fixed_dofs(system, layout):
    """The global indices of the bodies' Dirichlet dofs (the same set on every rank)."""
    fixed = []
    for i, (_, body) in enumerate(system.body_items()):   # (this rank's bodies: its blocks)
        own = layout.sizes[i]
        for bc in body.bcs:
            dofs, n_owned = bc.dof_indices()
            fixed += [layout.start + layout.offsets[i] + int(d) for d in dofs[:n_owned] if d < own]
    return set(np.concatenate(system.comm.allgather(np.array(fixed, dtype=np.int64))).tolist())


def check_law(law, what):
    """Refuse what is not a contact law (the engine names no model: it checks what it calls)."""
    for attr in ("reach", "energy", "slope", "quotient", "closest_points", "radii", "exclude"):
        if not hasattr(law, attr):
            raise ConstraintError(f"{what}: {law!r} is not a rod contact law (e.g. forms/rod_contact.py's RodContact)")
