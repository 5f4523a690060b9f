"""A mechanism: bodies joined by joints into one port-Hamiltonian system, one Newton per step.

    four_bar = System()
    crank   = four_bar.add("crank",   beam, length, n_elements=10, initial=..., supports=[...])
    coupler = four_bar.add("coupler", beam, ...)
    four_bar.join(pin, crank.end, coupler.start)
    four_bar.marker("marker", coupler.at(0.5 * length))
    run(four_bar, dt, t_end)

Each body keeps its own mesh, state space, forms and loads (rodfem/core/body.py);
a joint (rodfem/core/joints.py, physics in forms/joints.py) couples
points of two bodies through its multipliers.  The unknown of a step is the
block vector (x_1, ..., x_k, lambda) of all bodies and all joints' multipliers;
the residual is the bodies' residuals (assembled by DOLFINx into their
blocks) plus the joints' reactions and constraint rows; the Jacobian is one
PETSc matrix.  H = sum of the bodies' H; the supplied work is the bodies'
port work plus that of driven joints, so H_{n+1} - H_n = h y.u holds for the
whole system.  Only what the system has is assembled: no joint, no
multiplier block.
"""
import numpy as np
import ufl
from dolfinx import fem, mesh as dmesh
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from rodfem.fem import compat
from rodfem.core.body import Body
from rodfem.core.joints import ConstraintError, Joint, Point
from rodfem.nls.newton import Newton
from rodfem.core.problem import compile_forms


class BodyRef:
    """A body of a system, by name: its points for joints and markers."""

    def __init__(self, name, body):
        self.name, self.body = name, body

    @property
    def start(self):
        """The end s = 0."""
        return self._end("left")

    @property
    def end(self):
        """The end s = L."""
        return self._end("right")

    def _end(self, where, offset=()):
        if self.body.rigid:
            raise ConstraintError(f"body {self.name} is rigid: use {self.name}.point(offset), not an end")
        return Point(self, where, tuple(offset))

    def point(self, offset=()):
        """The material point at `offset` in the body's frame (rigid bodies; rod ends: start/end)."""
        if not self.body.rigid:
            raise ConstraintError(f"body {self.name} is flexible: use {self.name}.start or .end (or .at(s))")
        return Point(self, "body", tuple(offset))

    def at(self, s):
        """The node at arc length s (for markers)."""
        return Point(self, "node", (), float(s))


class System:
    """Bodies and joints as one discrete PH system (see the module docstring)."""

    def __init__(self, integrator="midpoint", comm=MPI.COMM_WORLD, newton_options=None, momentum=None):
        """momentum: write the total momentum maps p, L (about the origin) to the history; by
        default only for a free system (nothing supported or grounded), where they are conserved
        when no load acts."""
        self.integrator, self.comm, self.newton_options = integrator, comm, newton_options
        self.t = 0.0  # the time of the state x_n (the time loop advances it)
        self.momentum = momentum
        self.bodies, self.joints, self.markers, self.recorders = {}, [], {}, []
        self._ready = False

    # -- the sketch -------------------------------------------------------------
    def add(self, name, model, length=1.0, n_elements=1, loads=(), supports=(), initial=None, shape=None):
        """Place a body: a flexible one on [0, length] with n_elements cells (or `shape` = (length,
        initial), e.g. forms.planar_beam.straight(a, b)), or a rigid one (initial values only)."""
        if name in self.bodies or not name or "." in name:
            raise ValueError(f"body name {name!r} must be new, non-empty and without '.'")
        if shape is not None:
            if initial is not None:
                raise ValueError(f"body {name}: give either shape or initial, not both")
            length, initial = shape
        body = Body(model, length, n_elements, loads, supports, initial, self.integrator, self.comm, name)
        ref = BodyRef(name, body)
        self.bodies[name] = ref
        return ref

    def join(self, constraint, a, b, name="", drive=None):
        """Join point a to point b (or GROUND) by the joint `constraint` of forms/joints.py;
        `drive(t)` (zero at t = 0) prescribes its motion: g(q) = drive(t)."""
        for p in (a, b):
            if not isinstance(p, Point):
                raise ConstraintError(f"joint {name or constraint}: {p!r} is not a point (use body.start, .end, .point())")
            if p.body is not None and self.bodies.get(p.body.name) is not p.body:
                raise ConstraintError(f"joint {name or constraint}: body {p.body.name} is not in this system")
        if a.body is None and b.body is None:
            raise ConstraintError("a joint needs at least one body")
        joint = Joint(constraint, a, b, name or f"{getattr(constraint, '__name__', 'joint')}{len(self.joints) + 1}", drive)
        if any(j.name == joint.name for j in self.joints):
            raise ConstraintError(f"joint name {joint.name!r} is used twice")
        self.joints.append(joint)
        return joint

    def marker(self, name, point):
        """Record the position of `point` in the history as columns name_x, name_y (, name_z)."""
        self.markers[name] = point

    def record(self, columns):
        """Record more history columns: `columns(system)` returns a dict of numbers for the state
        x_{n+1}; it is called on every rank (it may be collective)."""
        self.recorders.append(columns)

    # -- building ---------------------------------------------------------------
    def build(self):
        """Compile every body's forms, bind the joints, make the block Newton (once)."""
        if self._ready:
            return self
        refs = list(self.bodies.values())
        if not refs:
            raise ValueError("a system needs at least one body")
        forms = {}
        for ref in refs:
            for key, f in ref.body.forms().items():
                if not key.startswith("obs:"):
                    forms[(ref.name, key)] = f
        free = not any(r.body.supports for r in refs) and not any(
            j.a.body is None or j.b.body is None for j in self.joints)
        if self.momentum or (self.momentum is None and free):   # total momentum maps
            for ref in refs:
                X1 = ref.body.space.split(ref.body.x1)
                for k, f in ref.body.momentum_forms(X1).items():
                    forms[(ref.name, "obs:" + k)] = f
        self.lam_space = None
        size = 0
        for j in self.joints:
            j.offset = size
            size += self._bind(j)
        if size:
            self._multiplier_block(size, forms)
        compiled = compile_forms(forms)
        self.compiled = compiled
        self.momenta = sorted({k[1][4:] for k in compiled if k[1].startswith("obs:")},
                              key=lambda c: ("pL".index(c[0]), c))
        self.assembler = BlockAssembler(self, compiled)
        self.assembler.check_independent()
        self.newton = Newton(assembler=self.assembler, options=self.newton_options)
        self.n_elements = sum(r.body.n_elements for r in refs if not r.body.rigid)
        self._ready = True
        return self

    def _multiplier_block(self, size, forms):
        """lambda of all joints: DG0 on a mesh of one cell (a space the block assembly can hold)."""
        m = dmesh.create_interval(self.comm, 1, [0.0, 1.0])
        el = compat.element("DG", m, 0, (size,)) if size > 1 else compat.element("DG", m, 0)
        self.lam_space = compat.functionspace(m, el)
        self.lam = fem.Function(self.lam_space)
        zero = fem.Constant(m, 0.0)
        dl = ufl.TestFunction(self.lam_space)
        F = zero * ufl.inner(self.lam, dl) * ufl.dx
        forms[("joints", "F")] = F
        forms[("joints", "J")] = ufl.derivative(F, self.lam)

    def _bind(self, joint):
        """Bind a joint to its points' frames and initial coordinates; returns its number of multipliers."""
        points = (joint.a, joint.b)
        sides = [None if p.body is None else point_coordinates(p, self.comm) for p in points]
        frames, q0s, scale = [], [], 1.0
        for k, (p, side) in enumerate(zip(points, sides)):
            if side is None:   # the ground: a fixed frame
                o, o_side = points[1 - k], sides[1 - k]
                dim = len(o.body.body.model.frame(o_side.unpack(o_side.values(0)), o.offset).x)
                fixed = ground_frame(p, dim)
                frames.append(lambda q, g=fixed: g)
                q0s.append(np.zeros(0))
            else:
                model, offset = p.body.body.model, p.offset
                frames.append(lambda q, s=side, mdl=model, off=offset: mdl.frame(s.unpack(q), off))
                q0s.append(side.values(0))
                scale = max(scale, float(np.max(np.abs(side.values(0)))))
        joint.sides = sides
        try:
            joint.bind(frames[0], frames[1], q0s[0], q0s[1], scale)
        except ConstraintError:
            raise
        except (ValueError, TypeError, IndexError) as err:   # e.g. an offset on a point that has none
            raise ConstraintError(f"joint {joint.name} ({joint.a.describe()} - {joint.b.describe()}): {err}") from None
        return joint.size

    # -- the time loop's view ---------------------------------------------------
    @property
    def loads(self):
        return [load for r in self.bodies.values() for load in r.body.loads]

    @property
    def supports(self):
        return [sup for r in self.bodies.values() for sup in r.body.supports]

    def set_time(self, t):
        self.build()
        for r in self.bodies.values():
            r.body.set_time(t)
        self.t_mid = t

    def predict(self, previous):
        self.build()
        A = self.assembler
        if previous is None:
            A.X1.array[:] = A.X0.array
        else:
            A.X1.array[:] = 2.0 * A.X0.array - previous

    def solve(self, step, t):
        h = float(next(iter(self.bodies.values())).body.h.value)
        self.assembler.times = (t - h, t, h)
        return self.newton.solve(step, t)

    def accept(self):
        A = self.assembler
        previous = A.X0.array.copy()
        A.X0.array[:] = A.X1.array
        A.push(A.X0, "x0")
        return previous

    @property
    def h(self):
        return _StepSize(self)

    # -- evaluation -------------------------------------------------------------
    def _sum(self, key):
        local = sum(fem.assemble_scalar(self.compiled[(n, key)]) for n in self.bodies
                    if self.compiled.get((n, key)) is not None)
        return self.comm.allreduce(local, op=MPI.SUM)

    def hamiltonian(self):
        """H(x_{n+1}) = sum of the bodies' H."""
        self.build()
        return self._sum("H")

    def supplied_work(self):
        """h y.u of the last step: the bodies' ports and the driven joints."""
        return self._sum("work") + self.assembler.joint_work

    @property
    def dissipates(self):
        """True if a body dissipates (rodfem/core/model.py: `dissipation`)."""
        self.build()
        return any(self.compiled.get((n, "dissipation")) is not None for n in self.bodies)

    def dissipated_energy(self):
        """h d_n of the last step: the sum over the dissipating bodies."""
        return self._sum("dissipation")

    def observe(self):
        self.build()
        obs = self.assembler.point_observables()
        for k in self.momenta:
            obs[k] = self._sum("obs:" + k)
        for columns in self.recorders:
            obs.update(columns(self))
        return obs

    @property
    def dofs(self):
        self.build()
        return self.assembler.X1.getSize()

    def describe_elements(self):
        return {name: r.body.describe_elements() for name, r in self.bodies.items()}

    def body(self, name):
        return self.bodies[name].body


class _StepSize:
    """system.h.value = dt sets the step of every body."""

    def __init__(self, system):
        self.system = system

    @property
    def value(self):
        return next(iter(self.system.bodies.values())).body.h.value

    @value.setter
    def value(self, dt):
        for r in self.system.bodies.values():
            r.body.h.value = dt


def ground_frame(point, dim):
    """The fixed Frame of a ground point in `dim` dimensions."""
    from rodfem.core.joints import Frame
    x = np.zeros(dim) if not point.offset else np.asarray(point.offset, dtype=float)
    if len(x) != dim:
        raise ConstraintError(f"{point.describe()}: a ground point in {dim} dimensions needs {dim} coordinates")
    R = np.eye(3) if point.s is None else np.asarray(point.s, dtype=float).reshape(3, 3)
    return Frame(x=x, d=[R[:, i] for i in range(3)] if dim == 3 else None, phi=0.0)


class PointCoordinates:
    """The dofs of a point's configuration coordinates q and their velocities v in its body's space.

    Local dof indices (this rank, -1 where not here), in the order of model.kinematics
    (field by field, component by component); `values(k)` is filled in by the assembler.
    """

    def __init__(self, point, q_dofs, v_dofs, layout):
        self.point, self.q_dofs, self.v_dofs, self.layout = point, q_dofs, v_dofs, layout
        self.size = len(q_dofs)
        self._values = {0: None}

    def unpack(self, q):
        """dict field -> values of the coordinate vector q."""
        out, k = {}, 0
        for name, n in self.layout:
            out[name] = np.asarray(q[k:k + n])
            k += n
        return out

    def values(self, which):
        return self._values[which]


def point_coordinates(point, comm):
    """PointCoordinates of `point` with the initial coordinates q(0) (collective)."""
    body = point.body.body
    S, model = body.space, body.model
    if point.where == "body":
        entities, dim = np.arange(body.mesh.topology.index_map(1).size_local, dtype=np.int32), 1
    elif point.where in ("left", "right"):
        entities, dim = body.facets[point.where], 0
    else:
        entities = dmesh.locate_entities(body.mesh, 0, lambda x: np.isclose(x[0], point.s))
        dim = 0
        found = comm.allreduce(len(entities), op=MPI.SUM)
        if not found:
            raise ConstraintError(f"point {point.describe()} at s = {point.s:g} is not a node of {point.body.name}")
    q_dofs, v_dofs, layout = [], [], []
    for q, v in model.kinematics.items():
        n = S.field(q).size
        layout.append((q, n))
        for name, out in ((q, q_dofs), (v, v_dofs)):
            sub = S.sub(name)
            for c in range(n):
                s = sub.sub(c) if S.field(name).shape else sub
                dofs = fem.locate_dofs_topological(s, dim, entities)
                out.append(int(dofs[0]) if len(dofs) else -1)
    pc = PointCoordinates(point, np.array(q_dofs), np.array(v_dofs), layout)
    # q(0) from the owning rank
    nloc = S.V.dofmap.index_map.size_local * S.V.dofmap.index_map_bs
    vals = np.full(pc.size, -np.inf)
    for i, d in enumerate(pc.q_dofs):
        if 0 <= d < nloc:
            vals[i] = body.x0.x.array[d]
    pc._values[0] = _max(comm, vals)
    return pc


def _add(A, rows, cols, values):
    """A[rows, cols] += values (PETSc reads the values row by row: make them C-contiguous)."""
    A.setValues(np.asarray(rows, dtype=PETSc.IntType), np.asarray(cols, dtype=PETSc.IntType),
                np.ascontiguousarray(values, dtype=PETSc.ScalarType), addv=PETSc.InsertMode.ADD)


def _max(comm, array):
    """Elementwise maximum over the ranks (each entry is known on the rank that owns it)."""
    array = np.ascontiguousarray(array, dtype=float if np.asarray(array).dtype.kind == "f" else np.int64)
    comm.Allreduce(MPI.IN_PLACE, array, op=MPI.MAX)
    return array


class BlockAssembler:
    """Residual and Jacobian of the system on the block vector (x_1, ..., x_k, lambda)."""

    def __init__(self, system, compiled):
        self.system, self.comm = system, system.comm
        refs = list(system.bodies.values())
        self.bodies = [r.body for r in refs]
        self.F = [compiled[(r.name, "F")] for r in refs]
        J = [compiled[(r.name, "J")] for r in refs]
        self.spaces = [b.space.V for b in self.bodies]
        self.x1s = [b.x1 for b in self.bodies]
        self.x0s = [b.x0 for b in self.bodies]
        if system.lam_space is not None:
            self.F.append(compiled[("joints", "F")])
            J.append(compiled[("joints", "J")])
            self.spaces.append(system.lam_space)
            self.x1s.append(system.lam)
            self.x0s.append(None)
        k = len(self.F)
        self.J = [[J[i] if i == j else None for j in range(k)] for i in range(k)]
        self.bcs = [bc for b in self.bodies for bc in b.bcs]
        self.X1 = fpetsc.create_vector_block(self.F)
        self.X0 = self.X1.duplicate()
        self.vector = self.X1
        self.sizes = [V.dofmap.index_map.size_local * V.dofmap.index_map_bs for V in self.spaces]
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)])
        self.start = self.X1.getOwnershipRange()[0]
        self.pull(self.X1, "x1")
        self.X1.copy(self.X0)
        self.joints = system.joints
        self.joint_work = 0.0
        self.times = (0.0, 0.0, 1.0)
        self._index_points()

    # -- block vector <-> the bodies' Functions ---------------------------------
    def pull(self, X, which):
        arr = X.getArray()
        for i, b in enumerate(self.bodies):
            arr[self.offsets[i]:self.offsets[i + 1]] = getattr(b, which).x.array[: self.sizes[i]]

    def push(self, X, which):
        arr = X.getArray(readonly=True)
        funcs = self.x1s if which == "x1" else self.x0s
        for i, f in enumerate(funcs):
            if f is not None:
                f.x.array[: self.sizes[i]] = arr[self.offsets[i]:self.offsets[i + 1]]
                f.x.scatter_forward()

    def update(self, xin):
        if xin.handle != self.X1.handle:
            xin.copy(self.X1)
        self.X1.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.push(self.X1, "x1")

    # -- global indices of the joints' and markers' coordinates ------------------
    def _global(self, block, local):
        """Global block index of local dof `local` of block `block` (-1 if not owned here)."""
        if local < 0 or local >= self.sizes[block]:
            return -1
        return self.start + self.offsets[block] + local

    def _index_points(self):
        """For every joint side and marker: global indices of q and v; one scatter to rank 0."""
        comm = self.comm
        index = {id(r.body): i for i, r in enumerate(self.system.bodies.values())}
        wanted = []

        def globals_of(pc):
            block = index[id(pc.point.body.body)]
            g = np.array([[self._global(block, d) for d in pc.q_dofs], [self._global(block, d) for d in pc.v_dofs]])
            return _max(comm, g)
        for j in self.joints:
            j.q_index, j.v_index = [], []
            for side in j.sides:
                if side is None:
                    continue
                g = globals_of(side)
                j.q_index.append(g[0])
                j.v_index.append(g[1])
                wanted += [g[0], g[1]]
            j.q_index = np.concatenate(j.q_index) if j.q_index else np.zeros(0, int)
            j.v_index = np.concatenate(j.v_index) if j.v_index else np.zeros(0, int)
            lam_block = len(self.bodies)
            j.lam_index = _max(comm, np.array([self._global(lam_block, j.offset + i) for i in range(j.size)]))
            wanted.append(j.lam_index)
        self.marker_points = {}
        for name, p in self.system.markers.items():
            pc = point_coordinates(p, comm)
            g = globals_of(pc)
            self.marker_points[name] = (pc, g[0])
            wanted.append(g[0])
        self.wanted = np.unique(np.concatenate(wanted)).astype(PETSc.IntType) if wanted else np.zeros(0, PETSc.IntType)
        # Dirichlet dofs among them: the joints leave those rows and columns alone
        bc_local = [(i, bc) for i, b in enumerate(self.bodies) for bc in b.bcs]
        fixed = []
        for i, bc in bc_local:
            dofs, n_owned = bc.dof_indices()
            fixed += [self._global(i, int(d)) for d in dofs[:n_owned]]
        self.fixed = set(np.concatenate(comm.allgather(np.array(fixed, dtype=int))).tolist())
        root = comm.rank == 0
        n = len(self.wanted) if root else 0
        self.gathered = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        is_from = PETSc.IS().createGeneral(self.wanted if root else np.zeros(0, PETSc.IntType), comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(self.X1, is_from, self.gathered, None)
        self.position = {int(g): k for k, g in enumerate(self.wanted)}
        self._positions = {}   # index array -> positions in the gathered values (found once)

    def check_independent(self):
        """Refuse a redundant or inconsistent set of joints: the joints' velocity constraints
        G(q_0) v = 0, restricted to the velocities not fixed by supports, must have full row rank
        (else the multipliers are not unique and Newton's matrix is singular)."""
        if not self.joints:
            return
        bad = None
        if self.comm.rank == 0:
            vals = self._values(self.X0)
            cols = sorted({int(g) for j in self.joints for g in j.v_index if int(g) not in self.fixed})
            where = {g: k for k, g in enumerate(cols)}
            rows = []
            for j in self.joints:
                G = np.einsum("kij,j->ki", j.Q, self._pick(vals, j.q_index)) + j.c
                block = np.zeros((j.size, len(cols)))
                for k, g in enumerate(j.v_index):
                    if int(g) in where:
                        block[:, where[int(g)]] += G[:, k]
                rows.append(block)
            G = np.vstack(rows)
            sv = np.linalg.svd(G, compute_uv=False) if G.size else np.zeros(0)
            rank = int(np.sum(sv > 1e-10 * max(sv.max(initial=0.0), 1.0)))
            if rank < G.shape[0]:
                names = ", ".join(j.name for j in self.joints)
                bad = (f"the joints ({names}) impose {G.shape[0]} conditions of which only {rank} are "
                       "independent (a redundant or inconsistent set, e.g. a joint at a supported end): "
                       "remove the redundant ones")
        else:
            self._values(self.X0)
        bad = self.comm.bcast(bad, root=0)
        if bad:
            raise ConstraintError(bad)

    def _values(self, X):
        """Values of X at the wanted global indices (on rank 0; None elsewhere)."""
        self.scatter.scatter(X, self.gathered, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.gathered.getArray(readonly=True).copy() if self.comm.rank == 0 else None

    def _pick(self, vals, idx):
        """vals at the global indices idx (positions looked up once per index array; the cache keeps
        the array itself, so a new array that reuses a freed array's id() is not mistaken for it)."""
        hit = self._positions.get(id(idx))
        if hit is None or hit[0] is not idx:
            hit = self._positions[id(idx)] = (idx, np.array([self.position[int(g)] for g in idx], dtype=int))
        return vals[hit[1]]

    # -- the joints' contributions ---------------------------------------------
    def _joint_terms(self, X):
        """Yield per joint: (rows_v, rows_lam, cols_q, cols_v, step terms) on rank 0."""
        v1, v0 = self._values(X), self._values(self.X0)
        if self.comm.rank != 0:
            return []
        t0, t1, h = self.times
        out = []
        for j in self.joints:
            q0, q1 = self._pick(v0, j.q_index), self._pick(v1, j.q_index)
            w0, w1 = self._pick(v0, j.v_index), self._pick(v1, j.v_index)
            lam = self._pick(v1, j.lam_index)
            out.append((j, j.step(q0, q1, w0, w1, lam, h, t0, t1), q1))
        return out

    def residual(self, xin, b):
        self.update(xin)
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector_block(b, self.F, self.J, bcs=self.bcs, x0=self.X1, scale=-1.0)
        work = 0.0
        for j, (r_v, r_lam, *_, w), _q1 in self._joint_terms(self.X1):
            keep = [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]
            b.setValues(j.v_index[keep].astype(PETSc.IntType), np.ascontiguousarray(r_v[keep]), addv=PETSc.InsertMode.ADD)
            b.setValues(j.lam_index.astype(PETSc.IntType), np.ascontiguousarray(r_lam), addv=PETSc.InsertMode.ADD)
            work += w
        b.assemblyBegin()
        b.assemblyEnd()
        self.joint_work = self.comm.bcast(work, root=0)

    def create_vector(self):
        return fpetsc.create_vector_block(self.F)

    def create_matrix(self):
        """The block matrix: each body's block with its own mesh's sparsity (DOLFINx 0.5's
        create_matrix_block would use the first block's mesh for all).  The joints' entries are
        inserted at the first assembly and kept (zeroEntries keeps the nonzero structure)."""
        A = compat.create_block_matrix(self.comm, [self.J[i][i] for i in range(len(self.J))])
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        A.setOption(PETSc.Mat.Option.NO_OFF_PROC_ENTRIES, False)   # rank 0 adds the joints' rows everywhere
        return A

    def jacobian(self, xin, A):
        A.zeroEntries()
        fpetsc.assemble_matrix_block(A, self.J, bcs=self.bcs)
        A.assemble(PETSc.Mat.AssemblyType.FLUSH)   # the Dirichlet diagonal was inserted; the joints add
        for j, (_rv, _rl, drv_dq, drv_dl, drl_dq, drl_dv, _w), _q1 in self._joint_terms(self.X1):
            rows = [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]   # momentum rows
            qcols = [k for k, g in enumerate(j.q_index) if int(g) not in self.fixed]
            vcols = rows
            lam = range(j.size)
            for (r_idx, r_sel), (c_idx, c_sel), block in (
                    ((j.v_index, rows), (j.q_index, qcols), drv_dq), ((j.v_index, rows), (j.lam_index, lam), drv_dl),
                    ((j.lam_index, lam), (j.q_index, qcols), drl_dq), ((j.lam_index, lam), (j.v_index, vcols), drl_dv)):
                if len(r_sel) and len(c_sel):
                    _add(A, r_idx[list(r_sel)], c_idx[list(c_sel)], block[np.ix_(list(r_sel), list(c_sel))])
        A.assemble()

    # -- outputs of joints and markers --------------------------------------------
    def point_observables(self):
        """Markers' positions, the joints' reactions lambda and the largest position residual |g|."""
        vals = self._values(self.X1)
        obs = {}
        if self.comm.rank == 0:
            t1 = self.times[1]
            worst = 0.0
            for j in self.joints:
                q1 = self._pick(vals, j.q_index)
                worst = max(worst, float(np.max(np.abs(j.position_residual(q1, t1)))) if j.size else 0.0)
                for i, lam in enumerate(self._pick(vals, j.lam_index)):
                    obs[f"{j.name}.lambda{i + 1}"] = float(lam)
            if self.joints:
                obs["constraint_residual"] = worst
            for name, (pc, qidx) in self.marker_points.items():
                model = pc.point.body.body.model
                x = model.frame(pc.unpack(self._pick(vals, qidx)), pc.point.offset).x
                for c, value in zip("xyz", x):
                    obs[f"{name}_{c}"] = float(value)
        return self.comm.bcast(obs, root=0)
