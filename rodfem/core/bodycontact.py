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
(the law's Coulomb `factor` times the slip v_t of the tubes' contact point at the midpoint) acts as f on
body a's contact point and -f on body b's.  The point is the material point x_c + u of a body's
section (u = -/+ rho n, the law's `arms`, in the section frame's coordinates beta: the law's
`section_coordinates`) for a body whose fields the law names as a section frame (`frame`: directors
and their rates, gathered with the positions), x_c for one without (a string).  The nodes share f as
they share the normal force, (1 - a, a) and (1 - b, b), and their director rows get beta_k times it:
the couple u x f on the section.  Its work h f . v_t <= 0 is the step's `dissipated`.  It needs the
nodes' velocities and h (`step(X0, h)`); Newton's matrix gets its derivatives in the positions and
directors at t_{n+1} and in the velocities and director rates (central differences).  Not in statics
(at rest nothing slips).

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
    (n_nodes x 3 each) and arc lengths s, sorted along the body (on every rank); with `frame` (the names of
    a section frame's fields and of their rates, forms/rod_contact.py's `frame`) also those of the frame d
    and its rates w (n_nodes x 3 x 3: node, director k, component), else d = w = None."""

    point = False   # a rigid body's centre: two nodes at the same place (a segment of zero length)

    def __init__(self, ref, layout, i, frame=None):
        body = ref.body
        model = body.model
        position = getattr(model, "position", None)
        velocity = getattr(model, "kinematics", {}).get(position)
        if body.rigid:
            return self._centre(ref, layout, i, position, velocity)
        if velocity is None or tuple(body.space.field(position).shape) != (3,):
            raise ConstraintError(f"contact with body {ref.name}: it must be a 3D rod or string (a centreline "
                                  "of 3 coordinates) or a 3D rigid body; planar bodies are not supported")
        names = [position, velocity] + ([*frame[0], *frame[1]] if frame is not None else [])
        for name in names:
            field = body.space.field(name)
            if field.family != "P" or tuple(field.shape) != (3,):
                raise ConstraintError(f"contact with body {ref.name}: its field {name} must be a continuous (P) 3-vector")
        l2g = layout.local_to_global(i)
        own = layout.sizes[i]
        comm = layout.comm
        tables = []
        for name in names:
            Vi, dofs = body.space.collapse(name)
            dofs = dofs.reshape(-1, 3)
            s = Vi.tabulate_dof_coordinates()[: len(dofs), 0]
            owned = np.all(dofs < own, axis=1)
            s, g = (np.concatenate(a) for a in zip(*comm.allgather((s[owned], l2g[dofs[owned]]))))
            s, keep = np.unique(np.round(s, 12), return_index=True)
            tables.append((s, g[keep]))
        s = tables[0][0]
        if any(len(t[0]) != len(s) or not np.allclose(t[0], s) for t in tables[1:]):   # pragma: no cover
            raise ConstraintError(f"contact with body {ref.name}: its position, velocity and frame nodes differ")
        self.name, self.s, self.q, self.v = ref.name, s, tables[0][1], tables[1][1]
        self.d = self.w = None
        if frame is not None:
            self.d = np.stack([t[1] for t in tables[2:5]], axis=1)
            self.w = np.stack([t[1] for t in tables[5:8]], axis=1)

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
        self.d = self.w = None   # no section frame (whatever `frame` says): friction at the centre, no couple


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

    def lines(self):
        """(line of a's nodes, line of b's nodes): b's is a's for self-contact."""
        return self.a, self.a if self.self_contact else self.b

    @property
    def framed(self):
        """Whether a section frame acts at either side's contact point (the friction's couples)."""
        return any(ln.d is not None for ln in self.lines())

    def indices(self, pairs, which):
        """Global indices of the pairs' nodes' dofs: (m, 4, 3) of 'q' or 'v', (m, 4, 3, 3) of the frame 'd' or
        its rates 'w' (-1, ignored, on a side without a frame)."""
        i, j = pairs[:, 0], pairs[:, 1]
        parts = []
        for line, k in zip(self.lines(), (i, j)):
            A = getattr(line, which)
            if A is None:
                A = np.full((len(line.s), 3, 3), -1, dtype=np.int64)
            parts += [A[k], A[k + 1]]
        return np.stack(parts, axis=1)

    def stack_frames(self, frames, pairs):
        """The pairs' nodes' frame values (m, 4, 3, 3) from {id(line): (n, 3, 3)} (zeros on a side without one)."""
        i, j = pairs[:, 0], pairs[:, 1]
        parts = []
        for line, k in zip(self.lines(), (i, j)):
            F = frames.get(id(line))
            if F is None:
                F = np.zeros((len(line.s), 3, 3))
            parts += [F[k], F[k + 1]]
        return np.stack(parts, axis=1)

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

    def friction(self, X0, X1, V0, V1, w, rule="discrete-gradient", frames=None):
        """(F, G, power): the friction forces on the pairs' nodes' position rows F (m, 4, 3) and frame rows G
        (m, 4, 3, 3; None without `frames`), and their power f . v_t <= 0 (m,) of the step (forms/rod_contact.py):
        f = factor(N, |v_t|^2) v_t at body a's contact point, -f at body b's, with the closest points'
        parameters and normal at X_m, the slip of the points' midpoint velocities and N = -w z.
        frames: None, or the nodes' directors and their rates (S0, S1, T0, T1), each (m, 4, 3, 3)."""
        Xm = 0.5 * (X0 + X1)
        d, a, b, n = self.law_points(Xm)
        share = np.stack([1.0 - a, a, b - 1.0, -b], axis=1)                   # (m, 4): a's nodes +, b's -
        Vm = 0.5 * (V0 + V1)
        beta = None
        if frames is not None:   # the contact point as the material point x_c + u of each side's section
            S0, S1, T0, T1 = frames
            Sm = 0.5 * (S0 + S1)
            weights = np.abs(share)                                           # (1 - a, a, 1 - b, b)
            rho_a, rho_b = self.law.arms(d, self.self_contact)
            beta = np.zeros((len(d), 4, 3))
            for side, (lo, u) in enumerate(((0, -rho_a[:, None] * n), (2, rho_b[:, None] * n))):
                if self.lines()[side].d is None:
                    continue
                D = np.einsum("mi,mikj->mkj", weights[:, lo:lo + 2], Sm[:, lo:lo + 2])   # the frame at the point
                beta[:, lo:lo + 2] = self.law.section_coordinates(D, u)[:, None, :]
            Vm = self.law.point_velocity(Vm.reshape(-1, 3), beta.reshape(-1, 3),
                                         (0.5 * (T0 + T1)).reshape(-1, 3, 3)).reshape(Vm.shape)
        rel = np.einsum("nk,nkj->nj", share, Vm)                               # v_c,a - v_c,b at the midpoint
        vt = rel - np.einsum("nj,nj->n", rel, n)[:, None] * n
        N = np.maximum(-w * self.normal_effort(X0, X1, rule), 0.0)
        f = self.law.friction.factor(N, np.einsum("nj,nj->n", vt, vt))[:, None] * vt
        F = share[:, :, None] * f[:, None, :]
        G = None if beta is None else beta[:, :, :, None] * F[:, :, None, :]
        return F, G, np.einsum("nj,nj->n", f, vt)

    def friction_jacobian(self, X0, X1, V0, V1, w, rule="discrete-gradient", frames=None):
        """(dR/dQ1, dR/dW1), each (m, r, r) [pair, row, column], of the friction's loads R = (F, G) (r = 12,
        or 48 with `frames`) in the positions and directors Q1 = (X1, S1), resp. the velocities and rates
        W1 = (V1, T1), at t_{n+1}: central differences."""
        m = len(X0)
        args = [X0, X1, V0, V1] + (list(frames) if frames is not None else [])

        def loads(values):
            F, G, _ = self.friction(*values[:4], np.repeat(w, len(values[0]) // m), rule,
                                    None if frames is None else tuple(values[4:]))
            return F.reshape(len(F), -1) if G is None else np.concatenate([F.reshape(len(F), -1), G.reshape(len(G), -1)], axis=1)

        scale_v = max(float(np.max(np.abs(V1), initial=0.0)), 1e-8)
        unknowns = [[(1, FD_STEP * max(self.R, 1e-12))], [(3, FD_STEP * scale_v)]]
        if frames is not None:
            unknowns[0].append((5, FD_STEP))
            unknowns[1].append((7, FD_STEP * max(float(np.max(np.abs(frames[3]), initial=0.0)), scale_v / max(self.R, 1e-12))))
        out = []
        for group in unknowns:
            columns = []
            for k, step in group:
                shape = args[k].shape[1:]
                size = int(np.prod(shape))
                E = np.eye(size).reshape(size, *shape) * step
                rep = [np.repeat(A, size, axis=0) for A in args]
                plus, minus = list(rep), list(rep)
                plus[k] = (args[k][:, None] + E[None]).reshape(-1, *shape)
                minus[k] = (args[k][:, None] - E[None]).reshape(-1, *shape)
                diff = (loads(plus) - loads(minus)).reshape(m, size, -1) / (2 * step)
                columns.append(np.transpose(diff, (0, 2, 1)))
            out.append(np.concatenate(columns, axis=2))
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
        frames = {}   # the section frame each body's friction acts on (the first rubbing law that names one)
        for law, a, b, name in items:
            for ref in (a, b):
                if ref is not None and not rest and getattr(law, "friction", None) is not None and frames.get(id(ref)) is None:
                    frames[id(ref)] = law.frame(ref.body.space.names)
        lines = {}
        for law, a, b, name in items:
            for ref in (a, b):
                if ref is not None and id(ref) not in lines:
                    lines[id(ref)] = Centreline(ref, layout, index[id(ref)], frames.get(id(ref)))
        self.lines = list(lines.values())
        self.pairings = [Pairing(law, lines[id(a)], None if b is None else lines[id(b)], name)
                         for law, a, b, name in items]
        self.rubs = not rest and any(getattr(p.law, "friction", None) is not None for p in self.pairings)
        # the gathered vector: each line's positions (then, with friction, velocities, frames and their rates)
        self.slots, wanted, k = [], [], 0
        for kind in ("q", "v", "d", "w") if self.rubs else ("q",):
            for ln in self.lines:
                idx = getattr(ln, kind)
                if idx is not None:
                    self.slots.append((kind, id(ln), k, idx.shape))
                    wanted.append(idx.ravel())
                    k += idx.size
        wanted = np.concatenate(wanted).astype(PETSc.IntType)
        root = self.comm.rank == 0
        self.gathered = PETSc.Vec().createSeq(len(wanted) if root else 0, comm=PETSc.COMM_SELF)
        is_from = PETSc.IS().createGeneral(wanted if root else np.zeros(0, PETSc.IntType), comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(X, is_from, self.gathered, None)
        self.x0 = self.s0 = None
        self.h = 0.0
        self._terms = []
        self._known = [set() for _ in self.pairings]   # the pairs (keys) whose entries the matrix's pattern holds
        self._fresh = [np.zeros(0, np.int64) for _ in self.pairings]   # candidate pairs' keys of the last iterate
        self.fixed_index = np.array(sorted(fixed), dtype=np.int64)
        self.work = self.dissipated = 0.0
        self.seconds = {"search": 0.0, "forces": 0.0, "matrix": 0.0}   # rank 0's CPU time in the contact (benchmarks)

    def gather(self, X):
        """{kind: {id(line): values}} of the state X (rank 0; None elsewhere): kind 'q' the node positions
        (n, 3); with friction also 'v' their velocities, 'd' the frames (n, 3, 3) and 'w' their rates (the
        lines with a frame)."""
        self.scatter.scatter(X, self.gathered, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self.comm.rank != 0:
            return None
        vals = self.gathered.getArray(readonly=True)
        out = {kind: {} for kind in ("q", "v", "d", "w")}
        for kind, line, k, shape in self.slots:
            out[kind][line] = vals[k:k + int(np.prod(shape))].reshape(shape).copy()
        return out

    def nodes(self, X):
        """{id(line): node positions (n, 3)} of the state X (rank 0; None elsewhere)."""
        state = self.gather(X)
        return None if state is None else state["q"]

    def step(self, X0, h=0.0):
        """The step of size h from x_n = X0 (collective)."""
        self.s0 = self.gather(X0)
        self.x0 = None if self.s0 is None else self.s0["q"]
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
                rubs = getattr(p.law, "friction", None) is not None and self.rubs
                rows = self._index(p, pairs, ("v", "w") if rubs and p.framed else ("v",))
                for kinds in (("q", "d"), ("v", "w")) if rubs else (("q",),):
                    cols = self._index(p, pairs, kinds if p.framed else kinds[:1])
                    r = np.repeat(rows, cols.shape[1], axis=1).ravel()
                    c = np.tile(cols, (1, rows.shape[1])).ravel()
                    keep = (r >= 0) & (c >= 0)
                    out.append((r[keep], c[keep]))
        grown = self.comm.bcast(bool(out), root=0)
        return out if grown else None

    @staticmethod
    def _index(p, pairs, kinds):
        """The global indices (m, 12 or 48 ...) of the pairs' dofs of the kinds ('q', 'v', 'd', 'w'), side by side."""
        return np.concatenate([p.indices(pairs, kind).reshape(len(pairs), -1) for kind in kinds], axis=1)

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
        state = self.gather(X)
        x1 = None if state is None else state["q"]
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
                V = None
                if rubs:   # (V0, V1, frames): the velocities, and the frames and rates at t_n, t_{n+1} (or None)
                    b = None if p.self_contact else id(p.b)
                    V = (p.stack(self.s0["v"][id(p.a)], None if b is None else self.s0["v"][b], pairs),
                         p.stack(state["v"][id(p.a)], None if b is None else state["v"][b], pairs),
                         tuple(p.stack_frames(src[kind], pairs) for kind in ("d", "w") for src in (self.s0, state))
                         if p.framed else None)   # (S0, S1, T0, T1)
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
            kinds = ("v",)
            if V is not None:   # friction: the load on the node is minus the residual's term
                F, G, power = p.friction(X0, X1, *V[:2], w, self.rule, V[2])
                vals = (vals - F).reshape(len(pairs), -1)
                if G is not None:
                    vals, kinds = np.concatenate([vals, -G.reshape(len(pairs), -1)], axis=1), ("v", "w")
                lost -= self.h * float(np.sum(power))
            rows = self._free(self._index(p, pairs, kinds).ravel())
            own = rows >= 0          # (a Vec does not ignore the index -1 as a Mat does: the supported rows out)
            b.setValues(rows[own], np.ascontiguousarray(vals.ravel()[own]), addv=PETSc.InsertMode.ADD)
        self.dissipated = self.comm.bcast(lost, root=0)
        self.seconds["forces"] += time.process_time() - start

    def jacobian(self, X, A):
        start = time.process_time()
        for p, pairs, X0, X1, w, V in self._terms:
            blocks = w[:, None, None] * p.jacobian(X0, X1, self.rest, self.rule)
            if V is None:
                parts = [(self._index(p, pairs, ("v",)), self._index(p, pairs, ("q",)), blocks)]
            else:   # the friction's rows (positions, frames) in the positions and frames, velocities and rates
                framed = V[2] is not None
                dq, dv = p.friction_jacobian(X0, X1, *V[:2], w, self.rule, V[2])
                dq[:, :12, :12] -= blocks
                rows = self._index(p, pairs, ("v", "w") if framed else ("v",))
                parts = [(rows, self._index(p, pairs, ("q", "d") if framed else ("q",)), -dq),
                         (rows, self._index(p, pairs, ("v", "w") if framed else ("v",)), -dv)]
            for rows, cols, vals in parts:
                rows, cols = self._free(rows), self._free(cols)
                for r, c, block in zip(rows, cols, np.ascontiguousarray(vals)):
                    A.setValues(r, c, block, addv=PETSc.InsertMode.ADD)
        self.seconds["matrix"] += time.process_time() - start

    def _friction_columns(self, p):
        """name.Ft_x, _y, _z: the friction force on body a (zero for self-contact), and name.Mf_x, _y, _z: the
        moment about the origin of all the pair's friction loads (forces and section couples, the discrete
        moment sum x_m x F + sum_k d_k,m x G_k of the nodes' loads), of the last step (its last Newton iterate):
        the rate at which friction changes the total angular momentum -- zero between two rods (to
        round-off), rho_b n x f per pair where only one side has a section (forms/rod_contact.py)."""
        Ft, Mf = np.zeros(3), np.zeros(3)
        for q, pairs, X0, X1, w, V in self._terms:
            if q is not p or V is None:
                continue
            F, G, _ = p.friction(X0, X1, *V[:2], w, self.rule, V[2])
            Xm = 0.5 * (X0 + X1)
            if not p.self_contact:
                Ft += (F[:, 0] + F[:, 1]).sum(axis=0)
            Mf += np.cross(Xm, F).sum(axis=(0, 1))
            if G is not None:
                Mf += np.cross(0.5 * (V[2][0] + V[2][1]), G).sum(axis=(0, 1, 2))
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
