"""A port-Hamiltonian system of bodies, joined by joints, one Newton per step.

    four_bar = System()
    crank   = four_bar.add("crank",   beam, length, n_elements=10, initial=..., supports=[...])
    coupler = four_bar.add("coupler", beam, ...)
    four_bar.join(pin, crank.end, coupler.start)
    four_bar.marker("marker", coupler.at(0.5 * length))
    run(four_bar, dt, t_end)

A single body is a System with one body (`rodfem.Problem` builds one).  Each body keeps its own
mesh, state space, forms and loads (rodfem/core/body.py); a joint (rodfem/core/joints.py,
physics in forms/joints.py) couples points of two bodies through its multipliers.  The unknown
of a step is the block vector X = (x_1, ..., x_k, lambda) of all bodies and all joints'
multipliers; the residual is the bodies' residuals plus the joints' reactions and constraint
rows, the Jacobian one PETSc matrix, both assembled by rodfem/fem/assembly.py (every body's
block by the fast assembly).  H = sum of the bodies' H; the supplied work is the bodies' port
work plus that of driven joints, so H_{n+1} - H_n = -h d_n + h y.u holds for the whole system.
Only what the system has is assembled: no joint, no multiplier block.

The time loop's view (rodfem/core/model.py, `SteppedSystem`): `t`, `dt`, `comm`,
`set_step(h)`, `set_time(t)`, `predict(previous)`, `solve(step, t)`, `accept()`,
`hamiltonian()`, `supplied_work()`, `dissipates`, `dissipated_energy()`, `observe()`.
"""
from typing import Callable, Optional

import numpy as np
import scipy.sparse as sp
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc

from rodfem.common.limits import check_elements
from rodfem.core.body import Body
from rodfem.core.bodycontact import CLEARANCE, BodyContacts, check_centre, check_law, fixed_dofs
from rodfem.core.components import Law
from rodfem.core.joint_batch import JointBatch, batchable
from rodfem.core.joint_ranks import RankJoints
from rodfem.core.joints import Frame, Joint, MovingGround, Point, QuadraticForms
from rodfem.core.kinds import Meshes, kind, shareable, twin_forms
from rodfem.core.placement import Placement, here, owners, share_points
from rodfem.core.servo import Servo, start_multipliers
from rodfem.core.spaces import dofs_per_element
from rodfem.errors import ConstraintError, NewtonFailure
from rodfem.fem.assembly import BlockAssembler, BlockLayout, BodyBlock, RankLayout, allreduce_max, allreduce_sum
from rodfem.fem.batch import Functionals, Segments
from rodfem.fem.jit import compile_forms
from rodfem.la.rank import row_rank
from rodfem.nls.newton import Newton, Solve


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

    distribute = False  # the default under mpirun: every body's mesh over all ranks (rodfem/core/placement.py)
    batch = True   # the default: bodies of the same compiled forms assembled together (serial)
    share = True   # the default: bodies of one kind share their mesh and compiled forms (rodfem/core/kinds.py)
    guard_crossing = True   # refuse (and so split) a step whose contact pairs may pass through each other

    def __init__(self, integrator: str = "midpoint", comm=MPI.COMM_WORLD, newton_options: Optional[dict] = None,
                 momentum: Optional[bool] = None, batch: Optional[bool] = None, share: Optional[bool] = None,
                 distribute: Optional[bool] = None):
        """momentum: write the total momentum maps p, L (about the origin) to the history; by
        default only for a free system (nothing supported or grounded), where they are conserved
        when no load acts.  batch: bodies of the same compiled forms assembled together
        (rodfem/fem/batch.py); False: body by body; None: `System.batch`.  share: bodies of one
        kind share their mesh, state space and compiled forms (rodfem/core/kinds.py); None: `System.share`.
        distribute: under mpirun, each body whole on one rank (rodfem/core/placement.py: many small
        bodies); False: every body's mesh over all ranks; None: `System.distribute`."""
        self.integrator, self.comm, self.newton_options = integrator, comm, newton_options
        if batch is not None:
            self.batch = batch
        if share is not None:
            self.share = share
        if distribute is not None:
            self.distribute = bool(distribute)
        self.distribute = self.distribute and comm.size > 1
        self.t = 0.0   # the time of the state x_n (the time loop advances it)
        self.dt = 1.0  # the step h
        self.momentum = momentum
        self.bodies, self.joints, self.components, self.markers, self.recorders = {}, [], [], {}, []
        self.contacts = []   # (law, a, b, name): contact between bodies' centrelines (rodfem/core/bodycontact.py)
        self._ready = False

    # -- the sketch -------------------------------------------------------------
    def add(self, name: str, model, length: float = 1.0, n_elements: int = 1, loads=(), supports=(),
            initial: Optional[dict] = None, shape=None, contacts=()) -> BodyRef:
        """Place a body: a flexible one on [0, length] with n_elements cells (or `shape` = (length,
        initial), e.g. rodfem.forms.planar_beam.straight(a, b)), or a rigid one (initial values only).
        Without `initial` a body starts in its model's `default_initial()` (a rod straight along x from
        the origin, a rigid body at the origin with d_i = e_i, both at rest).
        `contacts`: the body's interactions (rodfem/core/body.py), e.g. forms/contact.py's contacts
        with obstacles; their columns are named body.column."""
        if not isinstance(name, str) or name in self.bodies or not name or "." in name:
            raise ConstraintError(f"body name {name!r} must be new, non-empty and without '.'")
        if shape is not None:
            if initial is not None:
                raise ConstraintError(f"body {name}: give either shape or initial, not both")
            length, initial = shape
        return self._place(name, model, length, n_elements, loads, supports, initial, contacts)

    def _place(self, name, model, length, n_elements, loads, supports, initial, contacts=()):
        if self.distribute:   # (built on its rank when the system is built: rodfem/core/placement.py)
            return self._place_later(name, model, length, n_elements, loads, supports, initial, contacts)
        if self._ready:
            raise ConstraintError(f"body {name or model}: the system has been built (it has run); "
                                  "add every body before the first run")
        if not hasattr(self, "_meshes"):
            self._meshes = Meshes() if self.share else None
        body = Body(model, length, n_elements, loads, supports, initial, self.integrator, self.comm, name, contacts,
                    shared=self._meshes)
        ref = BodyRef(name, body)
        self.bodies[name] = ref
        return ref

    def _place_later(self, name, model, length, n_elements, loads, supports, initial, contacts=()):
        """A body to be built on its rank by `build` (a Placement until then; rodfem/core/placement.py)."""
        if self._ready:
            raise ConstraintError(f"body {name or model}: the system has been built (it has run); "
                                  "add every body before the first run")
        check_elements(n_elements, dofs_per_element(model.fields), MPI.COMM_SELF)
        ref = BodyRef(name, Placement(model, length, n_elements, loads, supports, initial, self.integrator, name,
                                      contacts))
        self.bodies[name] = ref
        return ref

    def join(self, constraint: Callable, a: Point, b: Point, name: str = "", drive: Optional[Callable] = None,
             motion: Optional[Callable] = None) -> Joint:
        """Join point a to point b (or GROUND) by the joint `constraint` of rodfem/forms/joints.py;
        `drive(t)` (zero at t = 0) prescribes its motion: g(q) = drive(t).  `motion(t)` = (x, R): the
        ground point a moves on this path (rodfem/core/joints.py, `MovingGround`; x(0), R(0) its own)."""
        self._check_points(f"joint {name or constraint}", a, b)
        name = name or f"{getattr(constraint, '__name__', 'joint')}{len(self.joints) + 1}"
        if motion is not None:
            if a.body is not None or drive is not None:
                raise ConstraintError(f"joint {name}: a motion moves the ground point a (give a = ground(...), no drive)")
            joint = MovingGround(constraint, a, b, name, motion)
        else:
            joint = Joint(constraint, a, b, name, drive)
        self._check_name(joint.name)
        self.joints.append(joint)
        return joint

    def servo(self, point: Point, path: Callable, inputs, axes=None, name: str = "") -> Servo:
        """Servo constraint (inverse dynamics, rodfem/core/servo.py): `point`'s coordinates (those
        along `axes`) follow path(t), starting where the point is, enforced by the unknown `inputs`
        (actuators placed on points, e.g. servo.along((1, 0, 0)).at(trolley)), as many as coordinates."""
        servo = Servo(point, path, inputs, axes, name or f"servo{len(self.joints) + 1}")
        for i in servo.inputs:
            self._check_points(f"{servo.describe()}: input {i.describe()}", i.a, i.b)
        self._check_points(servo.describe(), servo.a, point)
        self._check_name(servo.name)
        self.joints.append(servo)
        return servo

    def connect(self, law, a: Point, b: Point, name: str = ""):
        """Place a component of rodfem/forms/components.py (a spring, a damper, a control law) between
        point a and point b (or the ground): its energy joins H, its dissipation the `dissipated`
        column, its input's work `supplied`.  A controller made of parts (a tuple of laws: PD = a
        spring and a damper) places each, named name_label; returns the component(s)."""
        if isinstance(law, tuple) and law and all(isinstance(part, Law) for part in law):
            base = name or f"{law[0].label.split()[0]}{len(self.components) + 1}"
            return tuple(self.connect(part, a, b, f"{base}_{part.label.replace(' ', '_')}") for part in law)
        if not isinstance(law, Law):
            raise ConstraintError(f"component {name or '(unnamed)'}: a {type(law).__name__} is not a spring, damper "
                                  "or control law of rodfem.forms.components")
        self._check_points(f"component {name or law.label}", a, b)
        component = law.between(a, b, name or f"{law.label.replace(' ', '_')}{len(self.components) + 1}")
        self._check_name(component.name)
        self.components.append(component)
        return component

    def contact(self, law, a: BodyRef, b: Optional[BodyRef] = None, name: str = ""):
        """Contact between the centrelines of the flexible bodies a and b (3D rods, strings), or of a with
        itself (b None), by the law (forms/rod_contact.py: `RodContact`); its energy joins H, its columns
        are name.energy, name.N, name.Fn_x, ... (rodfem/core/bodycontact.py).  One of a, b may be a 3D
        rigid body: a sphere about its position, of the law's radius on its side."""
        name = name or f"{getattr(law, 'name', 'contact')}" + (f"{len(self.contacts) + 1}" if self.contacts else "")
        what = f"contact {name}"
        check_law(law, what)
        if self._ready:
            raise ConstraintError(f"{what}: the system has been built (it has run); place every contact before the first run")
        for ref in (a, b):
            if ref is None:
                continue
            if not isinstance(ref, BodyRef) or self.bodies.get(ref.name) is not ref:
                raise ConstraintError(f"{what}: {ref!r} is not a body of this system (use the BodyRef that add returns)")
        if b is a:
            raise ConstraintError(f"{what}: a body with itself is self-contact: give b = None")
        rigid = [k for k, ref in enumerate((a, b)) if ref is not None and ref.body.rigid]
        if rigid and (b is None or len(rigid) == 2):
            raise ConstraintError(f"{what}: a rigid body's sphere touches a rod or string (one rigid body per contact, "
                                  "no self-contact)")
        for k in rigid:   # the sphere about the rigid body's position (rodfem/core/bodycontact.py)
            ref = (a, b)[k]
            check_centre(ref.body, ref.name, getattr(ref.body.model, "position", None),
                         getattr(ref.body.model, "kinematics", {}).get(getattr(ref.body.model, "position", None)))
            radius = law.radii[k]
            if not radius > 0:
                raise ConstraintError(f"{what}: {('radius', 'radius_b')[k]}, the radius of rigid body {ref.name}'s "
                                      f"sphere, must be > 0 (got {radius!r})")
        self._check_name(name)
        if any(c[3] == name for c in self.contacts):
            raise ConstraintError(f"contact name {name!r} is used twice")
        self.contacts.append((law, a, b, name))
        return name

    def _check_points(self, what, a, b):
        if self._ready:
            raise ConstraintError(f"{what}: the system has been built (it has run); "
                                  "join and connect every point before the first run")
        for p in (a, b):
            if not isinstance(p, Point):
                raise ConstraintError(f"{what}: {p!r} is not a point (use body.start, .end, .point())")
            if p.body is not None and self.bodies.get(p.body.name) is not p.body:
                raise ConstraintError(f"{what}: body {p.body.name} is not in this system")
        if a.body is None and b.body is None:
            raise ConstraintError(f"{what} needs at least one body")

    def _check_name(self, name):
        names, nj, nc = getattr(self, "_names", (set(), 0, 0))
        if (nj, nc) != (len(self.joints), len(self.components)):   # (the names of those added since)
            names.update(j.name for j in self.joints[nj:] + self.components[nc:])
            self._names = (names, len(self.joints), len(self.components))
        if name in names:
            raise ConstraintError(f"joint or component name {name!r} is used twice")

    def marker(self, name: str, point: Point):
        """Record the position of `point` in the history as columns name_x, name_y (, name_z)."""
        self.markers[name] = point

    def record(self, columns: Callable):
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
            raise ConstraintError("a system needs at least one body")
        if self.distribute:
            self._place_on_ranks(refs)
        local = self._local_refs()
        # the unnamed body of a Problem writes its own columns (tip or mean position, momentum
        # maps when unsupported, its ports' columns); a System's bodies their total momentum maps,
        # and the system its markers, joints and recorders
        self.single = not self.named_bodies
        free = not any(r.body.supports for r in refs) and not any(
            j.a.body is None or j.b.body is None for j in self.joints + self.components)
        momentum = not self.single and (self.momentum or (self.momentum is None and free))
        templates = self._templates(local)   # body name -> the first body of its kind (rodfem/core/kinds.py)
        forms = self._forms([r for r in local if r.name not in templates], momentum)
        kinds = {t.name: t for t in templates.values()}
        alone = {n for n, t in kinds.items() if not shareable(t.body, {k: f for (m, k), f in forms.items() if m == n})}
        if alone:   # (a kind whose forms hold objects neither the bodies' nor the model's: body by body)
            forms.update(self._forms([r for r in local if templates.get(r.name, r).name in alone
                                      and r.name in templates], momentum))
            templates = {n: t for n, t in templates.items() if t.name not in alone}
        self.kinds = {n: t.name for n, t in templates.items()}   # body -> the body whose compiled forms it shares
        self._shared = self._share_points() if self.distributed else None
        size, self._quadratic_forms = 0, QuadraticForms()   # (equal joints and components: polarized once)
        for j in self.joints:
            j.offset = size
            size += self._bind(j)
        for c in self.components:
            self._bind_component(c)
        compiled = compile_forms(forms)
        keys = {}
        for n, k in forms:
            keys.setdefault(n, []).append(k)
        for name, t in templates.items():   # the other bodies of a kind: the template's kernels on their objects
            own = {k: forms[(t.name, k)] for k in keys[t.name]}
            twins = twin_forms(t.body, self.bodies[name].body, own, {k: compiled[(t.name, k)] for k in own})
            compiled.update({(name, k): f for k, f in twins.items()})
        self.compiled = {(r.name, k): compiled[(r.name, k)] for r in local for k in keys[templates.get(r.name, r).name]}
        self.columns = [k for (_, k) in self.compiled if k.startswith("obs:")]
        self.columns = list(dict.fromkeys(self.columns))
        if not self.single:
            self.columns.sort(key=lambda c: ("pL".index(c[4]) if c[4] in "pL" and c[5] == "_" else 2, c))
        if self.distributed:   # each rank: its bodies, then its joints' multipliers
            order = {id(r): i for i, r in enumerate(refs)}
            self.layout = RankLayout(self.comm, [r.body.space.V for r in local], [order[id(r)] for r in local],
                                     [self._joint_owner(j) for j in self.joints], [j.size for j in self.joints])
        else:
            self.layout = BlockLayout(self.comm, [r.body.space.V for r in refs], size)
        self._copies = {}
        self.points = PointIndex(self, self.layout) if (self.joints or self.components or self.markers) else None
        self.blocks = [BodyBlock(self.compiled[(r.name, "F")], self.compiled[(r.name, "J")], r.body.x1, r.body.bcs)
                       for r in local]
        self.joint_rows = JointRows(self.points) if (self.joints or self.components) else None
        self.body_contacts = (BodyContacts(self.contacts, local, self.layout, fixed_dofs(self, self.layout),
                                           self.layout.create_vector(), self.integrator) if self.contacts else None)
        parts = [c for c in (self.joint_rows, self.body_contacts) if c is not None]
        self.assembler = BlockAssembler(self.layout, self.blocks,
                                        (parts[0] if len(parts) == 1 else Couplings(parts)) if parts else None,
                                        batch=self.batch)
        self.X1 = self.assembler.vector
        self.X0 = self.layout.create_vector()
        self._pull(self.X1, "x1")
        self._pull(self.X0, "x0")
        if self.joints:
            self.points.check_independent(self.X0)
        if any(isinstance(j, Servo) for j in self.joints):
            start_multipliers(self)
        self.newton = Newton(assembler=self.assembler, options=self.newton_options)
        self.n_elements = sum(r.body.n_elements for r in refs if not r.body.rigid)
        self._scalar_forms, self._x1_values = {}, np.zeros(self.layout.size_local)
        self._evaluated = None   # the sums of the state x_{n+1}, in one reduction (`_evaluate`)
        for key in ["H", "work", "dissipation"] + self.columns:   # (built now: part of the build's cost)
            self._functionals(key)
        self._monitored = [(r.name, r.body) for r in local if r.body.contacts]
        self._loads = [load for r in local for load in r.body.loads]
        self._ready = True
        return self

    def _templates(self, refs):
        """Body name -> the first body of its kind (rodfem/core/kinds.py), for the bodies whose compiled
        forms are their template's on their own objects (not a Problem's body, not with `share` False)."""
        out, first = {}, {}
        if self.single or not self.share:
            return out
        for ref in refs:
            key = kind(ref.body)
            if key is None:
                continue
            if key not in first:
                first[key] = ref
            else:
                out[ref.name] = first[key]
        return out

    def _forms(self, refs, momentum):
        """The UFL forms of the bodies `refs`: {(body name, key): form} (rodfem/core/body.py's `forms`;
        a System's bodies: their momentum maps if `momentum`, and their interactions' columns)."""
        forms = {}
        for ref in refs:
            for key, f in ref.body.forms().items():
                if not key.startswith("obs:") or self.single:
                    forms[(ref.name, key)] = f
            if self.single:
                continue
            X1 = ref.body.space.split(ref.body.x1)
            if momentum:   # total momentum maps
                for k, f in ref.body.momentum_forms(X1).items():
                    forms[(ref.name, "obs:" + k)] = f
            for k, f in ref.body.interaction_forms(X1).items():   # the interactions' columns, body by body
                forms[(ref.name, "obs:" + f"{ref.name}.{k}")] = f
        return forms

    # -- bodies placed whole on ranks (rodfem/core/placement.py) ------------------------
    @property
    def distributed(self) -> bool:
        """True when the bodies are placed whole on ranks (built: `distribute` and enough bodies)."""
        return self.distribute and all(isinstance(r.body, Placement) or r.body.comm.size == 1
                                       for r in self.bodies.values())

    def _place_on_ranks(self, refs):
        """Build each body on its rank (`owners`); with fewer bodies than ranks, or contact between
        bodies, every body over all ranks instead (collective: an error on one rank is raised on all)."""
        if not all(isinstance(r.body, Placement) for r in refs):
            return
        spread = len(refs) < self.comm.size or bool(self.contacts)
        index = {id(r): k for k, r in enumerate(refs)}
        links = [(index[id(item.a.body)], index[id(item.b.body)]) for item in self.joints + self.components
                 if getattr(item, "a", None) is not None and getattr(item, "b", None) is not None
                 and id(item.a.body) in index and id(item.b.body) in index]
        rank = owners([r.body.weight for r in refs], self.comm.size, links) if not spread else None
        error = None
        if not hasattr(self, "_meshes"):
            self._meshes = Meshes() if self.share else None
        for k, ref in enumerate(refs):
            p = ref.body
            if spread:
                ref.body = Body(p.model, p.length, p.n_elements, p.loads, p.supports, p.initial, self.integrator,
                                self.comm, p.name, p.contacts, shared=self._meshes)
                continue
            p.owner = int(rank[k])
            if p.owner == self.comm.rank and error is None:
                try:
                    ref.body = p.make(self._meshes)
                except Exception as err:   # (the other ranks would wait for this one: raise it everywhere)
                    error = err
        if spread:
            self.distribute = False
            return
        found = self.comm.allgather(None if error is None else (type(error), str(error)))
        if error is not None:
            raise error
        kind, message = next(f for f in found if f is not None) if any(found) else (None, None)
        if kind is not None:
            raise (kind if issubclass(kind, (ConstraintError, ValueError)) else RuntimeError)(message)

    def _local_refs(self):
        """The BodyRefs of the bodies built on this rank, in the system's order (all of them unless distributed)."""
        return [r for r in self.bodies.values() if here(r.body)]

    def _share_points(self):
        """{id(point): PointCoordinates} of the joints', components' and markers' points (rodfem/core/placement.py)."""
        points = [p for item in self.joints + self.components for p in getattr(item, "points", (item.a, item.b))
                  if p.body is not None] + list(self.markers.values())
        return {id(p): pc for p, pc in zip(points, share_points(points, self.comm))}

    def _point_coordinates(self, p):
        """The PointCoordinates of a body's point (collective unless the bodies are placed on ranks)."""
        return self._shared[id(p)] if self._shared is not None else point_coordinates(p, self.comm)

    def _joint_owner(self, joint):
        """The rank of a joint's multipliers: that of its first body (distributed bodies)."""
        p = next(p for p in getattr(joint, "points", (joint.a, joint.b)) if p.body is not None)
        return p.body.body.owner if isinstance(p.body.body, Placement) else self.comm.rank

    def set_newton_options(self, options: Optional[dict]):
        """A new Newton with these options (the matrix and assembly are kept)."""
        self.build()
        self.newton_options = options
        self.newton = Newton(assembler=self.assembler, options=options)

    def _bind(self, joint):
        """Bind a joint to its points' frames and initial coordinates; returns its number of multipliers."""
        sides, frames, q0s, scale = self._frames(joint)
        joint.sides = sides
        try:
            if isinstance(joint, Servo):   # many points
                joint.bind(frames, q0s, scale)
            else:
                joint.bind(frames[0], frames[1], q0s[0], q0s[1], scale, forms=self._quadratic_forms)
        except ConstraintError:
            raise
        except (ValueError, TypeError, IndexError) as err:   # e.g. an offset on a point that has none
            raise ConstraintError(f"joint {joint.name} ({joint.a.describe()} - {joint.b.describe()}): {err}") from None
        return joint.size

    def _bind_component(self, component):
        """Bind a spring or damper to its points' frames and initial coordinates."""
        sides, frames, q0s, scale = self._frames(component)
        component.sides = sides
        try:
            component.bind(frames[0], frames[1], q0s[0], q0s[1], scale, self.integrator, forms=self._quadratic_forms)
        except ConstraintError:
            raise
        except (ValueError, TypeError, IndexError) as err:
            raise ConstraintError(f"{component.describe()}: {err}") from None

    def _frames(self, item):
        """The coordinates of a joint's or component's two points (a servo's: all of them): (sides,
        frame builders, q(0), scale)."""
        points = getattr(item, "points", (item.a, item.b))
        sides = [None if p.body is None else self._point_coordinates(p) for p in points]
        frames, q0s, scale = [], [], 1.0
        for k, (p, side) in enumerate(zip(points, sides)):
            if side is None:   # the ground: a fixed frame, of the dimension of the first body point
                o, o_side = next((o, s) for o, s in zip(points, sides) if s is not None)
                dim = len(o.body.body.model.frame(o_side.unpack(o_side.values(0)), o.offset).x)
                fixed = ground_frame(p, dim)
                frames.append(lambda q, g=fixed: g)
                q0s.append(np.zeros(0))
            else:
                model, offset = p.body.body.model, p.offset
                frames.append(lambda q, s=side, mdl=model, off=offset: mdl.frame(s.unpack(q), off))
                q0s.append(side.values(0))
                scale = max(scale, float(np.max(np.abs(side.values(0)))))
        return sides, frames, q0s, scale

    # -- the state: X <-> the bodies' Functions -----------------------------------
    def _segments(self, which):
        """The bodies' Functions x0 or x1 as segments of the block vector (one C call copies them all)."""
        if which not in self._copies:
            self._copies[which] = Segments([getattr(r.body, which) for r in self._local_refs()],
                                           [blk.lo for blk in self.blocks], [blk.hi - blk.lo for blk in self.blocks],
                                           self.comm)
        return self._copies[which]

    def _pull(self, X, which):
        self._segments(which).get(X.getArray())

    def _push(self, X, which):
        self._segments(which).put(X.getArray(readonly=True))
        if self.comm.size > 1 and not self.layout.distributed:   # the ghosts (none: bodies whole on ranks)
            for r in self.bodies.values():
                getattr(r.body, which).x.scatter_forward()

    def set_state(self, X):
        """x_n = x_{n+1} = X (a vector in the system's layout), pushed to every body."""
        self.build()
        self._evaluated = None
        X.copy(self.X0)
        X.copy(self.X1)
        self._push(self.X0, "x0")
        self._push(self.X1, "x1")

    # -- the time loop's view ---------------------------------------------------
    @property
    def loads(self):
        return [load for r in self.bodies.values() for load in r.body.loads]

    @property
    def supports(self):
        return [sup for r in self.bodies.values() for sup in r.body.supports]

    def set_step(self, h: float):
        """The step h of the next steps (every body's h)."""
        self.dt = float(h)
        if getattr(self, "_h_set", None) == self.dt:   # (every body has it: a step like the last)
            return
        for r in self._local_refs():
            r.body.h.value = h
        self._h_set = self.dt if self._ready or not self.distribute else None   # (placed bodies: built later)

    def set_time(self, t: float):
        """Inputs u(t) for the step (t = t_{n+1/2})."""
        self.build()
        for load in self._loads:   # (a Load given as an array returns at once)
            load.update(t)

    def predict(self, previous, ratio=1.0):
        """Newton's start x_{n+1}^0 = x_n + r (x_n - x_{n-1}), r = h_n / h_{n-1} (`ratio`; 2 x_n - x_{n-1}
        for equal steps), x_n if `previous` is None; x_n is read from the bodies (a change made to a
        body's x0 between steps takes effect)."""
        self.build()
        self._evaluated = None
        self._pull(self.X0, "x0")
        if previous is None:
            self.X0.copy(self.X1)
        elif ratio == 1.0:
            self.X1.getArray()[:] = 2.0 * self.X0.getArray(readonly=True) - previous
        else:
            x0 = self.X0.getArray(readonly=True)
            self.X1.getArray()[:] = x0 + ratio * (x0 - previous)

    def snapshot(self):
        """What a step changes of the loop's state: x_n and the control laws' states (`restore` puts them back:
        a rejected step of the step-size control, rodfem/analysis/stepping.py).  x_n is read from the bodies, as
        `predict` does: a change made to a body's x0 after `build` (a scene's static equilibrium) is x_n."""
        self.build()
        self._pull(self.X0, "x0")
        return (self.X0.getArray(readonly=True).copy(),
                [list(c.law.state) for c in self.components if getattr(c, "stateful", False)])

    def restore(self, snapshot):
        """x_n = x_{n+1} and the control laws' states of `snapshot`."""
        x, states = snapshot
        self._evaluated = None
        self.X0.getArray()[:] = x
        self.X0.copy(self.X1)
        self._push(self.X0, "x0")
        self._push(self.X1, "x1")
        for c, state in zip([c for c in self.components if getattr(c, "stateful", False)], states):
            c.law.state = list(state)

    def field_groups(self):
        """The owned entries of the loop's state vector by body and field: a list of (indices, paired), the same
        number on every rank; the step-size control (rodfem/analysis/stepping.py) measures each field against
        its own size.  The multipliers (constraint forces, algebraic: the joints' and the bodies' fields at
        t_{n+1} that the step does not carry over, `Body.algebraic_fields`) are left out: their values at
        the middle and the end of a doubled step are not two approximations of one quantity.

        `paired` (else None) marks a velocity of a constrained body (one with multipliers of its own or a
        joint's point): the indices of the configuration it moves (`model.kinematics`).  Its end-of-step
        values are index-2 variables: the constraint rows G(q_m) v_m = 0 hold the midpoint velocity, and
        v_{n+1} = 2 v_m - v_n carries an undamped (-1)^n component along G^T that one step of h and two of
        h/2 leave with opposite signs whatever h; the control measures it by the displacement h e_v it
        makes (the index-2 components scaled by h, Hairer & Wanner, Solving Ordinary Differential
        Equations II, Springer 1996, sec. VII.8)."""
        self.build()
        joined = {id(p.body.body) for j in self.joints for p in getattr(j, "points", (j.a, j.b)) if p.body is not None}
        per_body = {}   # body's place in the system -> its groups
        order = {id(r): i for i, r in enumerate(self.bodies.values())}
        for blk, ref in zip(self.blocks, self._local_refs()):
            groups = per_body.setdefault(order[id(ref)], [])
            body, owned = ref.body, blk.hi - blk.lo
            algebraic = set(body.algebraic_fields())
            constrained = bool(algebraic) or id(body) in joined
            velocity_of = {v: q for q, v in body.model.kinematics.items()} if constrained else {}

            def entries(name):
                dofs = body.space.field_dofs(name) if body.rigid else body.space.collapse(name)[1]
                dofs = np.asarray(dofs, dtype=np.int64).ravel()
                return blk.lo + dofs[dofs < owned]
            for f in body.space.fields:
                if f.name in algebraic:
                    continue
                q = velocity_of.get(f.name)
                groups.append((entries(f.name), None if q is None else entries(q)))
        if self.distributed:   # the groups of the other ranks' bodies, empty here
            none = np.zeros(0, np.int64)
            shapes = self.comm.allgather({b: [p is not None for _, p in g] for b, g in per_body.items()})
            for part in shapes:
                for b, paired in part.items():
                    per_body.setdefault(b, [(none, none if p else None) for p in paired])
        return [g for b in sorted(per_body) for g in per_body[b]]

    def state(self):
        """x_{n+1} as an array (the owned entries of this rank)."""
        return self.X1.getArray(readonly=True).copy()

    def solve(self, step: int, t: float) -> Solve:
        """x_{n+1} at time t by Newton (raises NewtonFailure; also for a step whose contact pairs may have passed
        through each other: rodfem/core/bodycontact.py, `BodyContacts.crossing`)."""
        self._evaluated = None
        if self.points is not None:
            self.points.step(self.X0, t - self.dt, t, self.dt)
        if self.body_contacts is not None:
            self.body_contacts.step(self.X0, self.dt)
        solve = self.newton.solve(step, t)
        if self.body_contacts is not None and self.guard_crossing:
            clearance, name, pair = self.body_contacts.crossing(self.X1)
            if not clearance >= CLEARANCE:
                raise NewtonFailure(step, t, solve.residual, solve.iterations,
                                    f"contact {name}: segments {pair} come within {clearance:.3g} R of each other "
                                    f"in the step (at least {CLEARANCE:g} R: they may pass through each other)")
        return solve

    def accept(self):
        """x_n <- x_{n+1} (and the control laws' states); returns the old x_n (for the next prediction)."""
        self._evaluated = None
        if any(getattr(c, "stateful", False) for c in self.components):
            self.points.advance(self.X0, self.X1)
        previous = self.X0.getArray(readonly=True).copy()
        self.X1.copy(self.X0)
        self._push(self.X0, "x0")
        return previous

    # -- evaluation -------------------------------------------------------------
    def _sum(self, key):
        """The sum over the bodies of the functional `key` at their states x1 (summed in the bodies' order)."""
        X = self._x1_values
        self._segments("x1").get(X)   # (what the bodies' Functions hold: a scene may have set them)
        total = sum(self._functionals(key).values(X))
        return total if self.comm.size == 1 else self.comm.allreduce(total, op=MPI.SUM)

    def _sums(self, keys):
        """{key: _sum(key)} for several functionals: the bodies' states read once, one reduction."""
        X = self._x1_values
        self._segments("x1").get(X)
        totals = [sum(self._functionals(k).values(X)) for k in keys]
        if self.comm.size > 1 and totals:
            totals = self.comm.allreduce(np.array(totals), op=MPI.SUM).tolist()
        return dict(zip(keys, totals))

    def _evaluate(self):
        """Under mpirun, the sums over the ranks a step's row needs, of the state x_{n+1}, in one reduction:
        {key: total} of the bodies' H, work, dissipation and history columns ("obs:..."), the joints' and
        components' supplied work and dissipated energy ("joints.work", "joints.dissipated"), and with the
        joints' terms on the ranks of their rows (rodfem/core/joint_ranks.py, `_observed_on_ranks`) every
        joint's multipliers ("lambda": each owned by one rank) and their largest position residual
        ("constraint_residual").  Kept until the state changes (solve, predict, accept, set_state, restore)."""
        if self._evaluated is not None:
            return self._evaluated
        X = self._x1_values
        self._segments("x1").get(X)   # (what the bodies' Functions hold: a scene may have set them)
        keys = ["H", "work", "dissipation"] + self.columns
        local = [sum(self._functionals(k).values(X)) for k in keys]
        local += list(self.joint_rows._sums) if self.joint_rows is not None else [0.0, 0.0]
        keys += ["joints.work", "joints.dissipated"]
        ranked = self._observed_on_ranks()
        if ranked:   # the multipliers (this rank's in their places) and the largest |g| of each rank
            lam = np.zeros(len(self.layout.multipliers))
            k, at = self.layout.owned_multipliers()
            lam[k] = self.X1.getArray(readonly=True)[at]
            gap = np.zeros(self.comm.size)
            gap[self.comm.rank] = self.points.ranked.worst_gap(self.X1, self.points.times[1])
            local = np.concatenate([local, lam, gap])
        total = allreduce_sum(self.comm, local)
        out = dict(zip(keys, total[:len(keys)].tolist()))
        if ranked:
            n = len(self.layout.multipliers)
            out["lambda"] = total[len(keys):len(keys) + n].tolist()
            out["constraint_residual"] = float(np.max(total[len(keys) + n:]))
        self._evaluated = out
        return out

    def _observed_on_ranks(self) -> bool:
        """True when every joint's read-out comes from the ranks of its rows (bodies whole on ranks, the
        plain joints only: no component, servo or marker read on rank 0)."""
        p = self.points
        return p is not None and p.ranked is not None and not p.rooted and not self.markers

    def _total(self, key):
        """The sum over the ranks of the functional `key` at x_{n+1} (collective)."""
        return self._sum(key) if self.comm.size == 1 else self._evaluate()[key]

    def _functionals(self, key):
        """The bodies' forms `key` (rodfem/fem/batch.py: those of the same compiled form together)."""
        if key not in self._scalar_forms:
            local = self._local_refs()
            forms = [self.compiled.get((r.name, key)) for r in local]
            self._scalar_forms[key] = Functionals(forms, [r.body.x1 for r in local],
                                                  [blk.lo for blk in self.blocks], self.layout.size_local, self.batch)
        return self._scalar_forms[key]

    def assemble(self, compiled) -> float:
        """A compiled scalar form, summed over the ranks."""
        return self.comm.allreduce(fem.assemble_scalar(compiled), op=MPI.SUM)

    def hamiltonian(self) -> float:
        """H(x_{n+1}) = sum of the bodies' H, of the components' and of the contacts' stored energies."""
        self.build()
        stored = self.points.stored_energy(self.X1) if self.components else 0.0
        if self.body_contacts is not None:
            stored += self.body_contacts.energy(self.X1)
        return self._total("H") + stored

    def supplied_work(self) -> float:
        """h y.u of the last step: the bodies' ports, the driven joints and the servos' inputs."""
        if self.comm.size > 1:
            return self._total("work") + self._evaluate()["joints.work"]
        joints = self.joint_rows.work if self.joint_rows is not None else 0.0
        return self._sum("work") + joints

    @property
    def dissipates(self) -> bool:
        """True if a body (rodfem/core/model.py: `dissipation`) or a component (a damper) dissipates."""
        self.build()
        mine = any(self.compiled.get((n, "dissipation")) is not None for n in self.bodies)
        if self.distributed:   # (the bodies of other ranks)
            mine = self.comm.allreduce(mine, op=MPI.LOR)
        return (mine or any(c.dissipative for c in self.components)
                or (self.body_contacts is not None and self.body_contacts.rubs))

    def dissipated_energy(self) -> float:
        """h d_n of the last step: the sum over the dissipating bodies, dampers and the contacts' friction."""
        if self.comm.size > 1:
            return (self._total("dissipation") + (self._evaluate()["joints.dissipated"] if self.components else 0.0)
                    + (self.body_contacts.dissipated if self.body_contacts is not None else 0.0))
        return (self._sum("dissipation") + (self.joint_rows.dissipated if self.components else 0.0)
                + (self.body_contacts.dissipated if self.body_contacts is not None else 0.0))

    def observe(self) -> dict:
        """The history's columns of the state x_{n+1}."""
        self.build()
        obs = {}
        if self.comm.size > 1:
            total = self._evaluate()
            columns = {k[4:]: total[k] for k in self.columns}
        else:
            columns = {k[4:]: v for k, v in self._sums(self.columns).items()}
        if self.single:
            obs.update(columns)
        if self._observed_on_ranks():   # (the same columns as PointIndex.observe)
            obs.update(zip(self.points.lam_names, total["lambda"]))
            if self.joints:
                obs["constraint_residual"] = total["constraint_residual"]
        elif self.points is not None:
            obs.update(self.points.observe(self.X1))
        if not self.single:
            obs.update(columns)
        if self.body_contacts is not None:
            obs.update(self.body_contacts.observe(self.X1))
        for name, body in self._monitored:   # (the bodies with interactions)
            for k, value in body.monitor().items():
                obs[f"{name}.{k}" if name else k] = value
        for columns in self.recorders:
            obs.update(columns(self))
        return obs

    @property
    def dofs(self) -> int:
        self.build()
        return self.layout.size_global

    def describe_elements(self):
        if list(self.bodies) == [""]:   # rodfem.Problem's one body
            return next(iter(self.bodies.values())).body.describe_elements()
        return {r.name: r.body.describe_elements() for r in self._local_refs()}

    def body(self, name):
        return self.bodies[name].body

    def body_items(self):
        """[(name, Body)] in the order of the block vector (the bodies of this rank, when placed on ranks)."""
        return [(ref.name, ref.body) for ref in self._local_refs()]

    def field_values(self, name: str, state: str = "x1") -> np.ndarray:
        """The values of field `name` at this rank's nodes of its bodies that have the field, rows [n, size] in
        the order of the block vector (a rigid body: one row), from x_n ("x0") or x_{n+1} ("x1"): one copy of
        the state and one indexing, whatever the number of bodies (a history column over 1000 rigid links)."""
        self.build()
        if ("values", name) not in self._copies:
            index, size = [], None
            for blk, ref in zip(self.blocks, self._local_refs()):
                body = ref.body
                if name not in [f.name for f in body.space.fields]:
                    continue
                size = body.space.field(name).size
                dofs = body.space.field_dofs(name) if body.rigid else body.space.collapse(name)[1]
                dofs = np.asarray(dofs, dtype=np.int64).ravel()
                index.append(blk.lo + dofs[dofs < blk.hi - blk.lo])
            self._copies[("values", name)] = (np.concatenate(index) if index else np.zeros(0, np.int64), size or 1)
        index, size = self._copies[("values", name)]
        if ("work", state) not in self._copies:
            self._copies[("work", state)] = self.layout.create_vector()
        X = self._copies[("work", state)]
        self._pull(X, state)
        return X.getArray(readonly=True)[index].reshape(-1, size)

    @property
    def named_bodies(self) -> bool:
        """True for bodies placed by `add` (results labelled body by body); False for the one
        unnamed body of a `rodfem.Problem`."""
        return list(self.bodies) != [""]


class PointIndex:
    """The global indices of the joints' and markers' coordinates q, velocities v and multipliers
    lambda in the system's block vector, and one scatter of those values to rank 0 (where the
    joints' small dense terms are computed)."""

    def __init__(self, system, layout):
        self.system, self.comm, self.layout = system, system.comm, layout
        self.joints = system.joints
        blocks = {id(r.body): i for i, r in enumerate(system.bodies.values())}
        l2g = {}

        def globals_of(pc):
            i = blocks[id(pc.point.body.body)]
            if layout.distributed:   # (each body whole on one rank: its dofs from its first)
                return np.array([layout.body_start[i] + np.asarray(d, np.int64) for d in (pc.q_dofs, pc.v_dofs)])
            if i not in l2g:
                l2g[i] = layout.local_to_global(i)
            own = layout.sizes[i]
            g = np.array([[l2g[i][d] if 0 <= d < own else -1 for d in dofs] for dofs in (pc.q_dofs, pc.v_dofs)])
            return allreduce_max(self.comm, g)
        self.components = system.components
        wanted = []
        for j in self.joints + self.components:
            q, v = [], []
            for side in j.sides:
                if side is not None:
                    g = globals_of(side)
                    q.append(g[0])
                    v.append(g[1])
            j.q_index = np.concatenate(q) if q else np.zeros(0, np.int64)
            j.v_index = np.concatenate(v) if v else np.zeros(0, np.int64)
            j.lam_index = layout.multipliers[j.offset:j.offset + j.size] if j in self.joints else np.zeros(0, np.int64)
            wanted += [j.q_index, j.v_index, j.lam_index]
        self.marker_points = {}
        for name, p in system.markers.items():
            pc = system._point_coordinates(p)
            g = globals_of(pc)
            self.marker_points[name] = (pc, g[0])
            wanted.append(g[0])
        self.wanted = np.unique(np.concatenate(wanted)).astype(PETSc.IntType) if wanted else np.zeros(0, PETSc.IntType)
        # Dirichlet dofs among them: the joints leave those rows and columns alone
        self.fixed = fixed_dofs(system, layout)
        root = self.comm.rank == 0
        self.gathered = PETSc.Vec().createSeq(len(self.wanted) if root else 0, comm=PETSc.COMM_SELF)
        is_from = PETSc.IS().createGeneral(self.wanted if root else np.zeros(0, PETSc.IntType), comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(system.X1 if hasattr(system, "X1") else layout.create_vector(),
                                              is_from, self.gathered, None)
        position = {int(g): k for k, g in enumerate(self.wanted)}
        for j in self.joints + self.components:   # positions of each joint's indices in the gathered values
            j.q_at, j.v_at, j.lam_at = ([position[int(g)] for g in idx] for idx in (j.q_index, j.v_index, j.lam_index))
            j.rows = [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]    # momentum rows
            j.qcols = [k for k, g in enumerate(j.q_index) if int(g) not in self.fixed]
        self.marker_at = {name: [position[int(g)] for g in qidx] for name, (pc, qidx) in self.marker_points.items()}
        # the joints' multiplier columns, in the joints' order: names and positions in the gathered values
        self.lam_names = [f"{j.name}.{getattr(j, 'multiplier', 'lambda')}{i + 1}" for j in self.joints
                          for i in range(len(j.lam_at))]
        self.lam_at = np.array([k for j in self.joints for k in j.lam_at], dtype=np.int64)
        # the plain joints' terms as stacked arrays (rodfem/core/joint_batch.py)
        plain = [j for j in self.joints if batchable(j)]
        self.batch = JointBatch(plain, self.fixed) if plain else None
        self.unbatched = [j for j in self.joints if self.batch is None or not batchable(j)]
        # bodies placed whole on ranks: the plain joints' terms on the ranks of their rows (rodfem/core/joint_ranks.py)
        self.ranked = RankJoints(plain, self.fixed, layout, layout.create_vector()) if layout.distributed and plain else None
        self.rooted = self.ranked is None or bool(self.unbatched or self.components)   # terms computed on rank 0
        self.x0_values, self.times = None, (system.t, system.t, system.dt)   # x_0 at its time: no step yet

    def values(self, X):
        """Values of X at the wanted global indices (on rank 0; None elsewhere)."""
        self.scatter.scatter(X, self.gathered, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.gathered.getArray(readonly=True).copy() if self.comm.rank == 0 else None

    def step(self, X0, t0, t1, h):
        """The step from x_n (X0) at t0 to t1 = t0 + h (x_n's values on rank 0 only if terms are computed there)."""
        if self.ranked is not None:
            self.ranked.step(X0)
        self.x0_values, self.times = self.values(X0) if self.rooted else None, (t0, t1, h)

    def advance(self, X0, X1):
        """The stateful control laws' states at t_{n+1} (computed on rank 0, then the same on every rank)."""
        v0, v1 = self.values(X0), self.values(X1)
        t0, t1, h = self.times
        stateful = [c for c in self.components if getattr(c, "stateful", False)]
        if self.comm.rank == 0:
            for c in stateful:
                c.advance(v0[c.q_at], v1[c.q_at], v0[c.v_at], v1[c.v_at], h, t0, t1)
        states = self.comm.bcast([list(c.law.state) for c in stateful], root=0)
        for c, state in zip(stateful, states):
            c.law.state = list(state)

    def stored_energy(self, X) -> float:
        """The springs' stored energy sum V(q, t) at the state X, t = t_{n+1} of the last step (collective;
        the same on every rank)."""
        vals = self.values(X)
        V = 0.0
        if self.comm.rank == 0:
            V = sum(c.energy(vals[c.q_at], self.times[1]) for c in self.components if hasattr(c, "energy"))
        return self.comm.bcast(V, root=0)

    def check_independent(self, X0):
        """Refuse a redundant or inconsistent set of joints: the joints' velocity constraints
        G(q_0) v = 0, restricted to the velocities not fixed by supports, must have full row rank
        (else the multipliers are not unique and Newton's matrix is singular)."""
        bad = None
        vals = self.values(X0)
        if self.comm.rank == 0:
            free = [[int(g) for g in j.v_index if int(g) not in self.fixed] for j in self.joints]
            blocks = []
            for j, cols in zip(self.joints, free):
                G = np.einsum("kij,j->ki", j.Q, vals[j.q_at]) + j.c
                blocks.append(G[:, [k for k, g in enumerate(j.v_index) if int(g) not in self.fixed]])
            rank, rows = 0, 0
            for members in coupled(free):   # (G is block diagonal over the joints sharing no velocity)
                cols = sorted({g for m in members for g in free[m]})
                where = {g: k for k, g in enumerate(cols)}
                entries, r = [], 0
                for m in members:
                    size = self.joints[m].size
                    i, k = np.meshgrid(np.arange(r, r + size), np.arange(len(free[m])), indexing="ij")
                    entries.append((i.ravel(), np.array([where[g] for g in free[m]], dtype=np.int64)[k.ravel()],
                                    blocks[m].ravel()))
                    r += size
                i, k, value = (np.concatenate(e) for e in zip(*entries))
                rank += row_rank(sp.coo_matrix((value, (i, k)), shape=(r, len(cols))))   # (duplicates summed)
                rows += r
            if rank < rows:
                names = ", ".join(j.name for j in self.joints)
                bad = (f"the joints ({names}) impose {rows} conditions of which only {rank} are "
                       "independent (a redundant or inconsistent set, e.g. a joint at a supported end): "
                       "remove the redundant ones")
        bad = self.comm.bcast(bad, root=0)
        if bad:
            raise ConstraintError(bad)

    def observe(self, X):
        """Markers' positions, the joints' reactions lambda and the largest position residual |g|, the
        springs' energies V and the control laws' inputs u."""
        vals = self.values(X)
        obs = {}
        if self.comm.rank == 0:
            t1 = self.times[1]
            worst = self.batch.worst_gap(vals, t1) if self.batch is not None else 0.0
            for j in self.unbatched:
                worst = max(worst, float(np.max(np.abs(j.position_residual(vals[j.q_at], t1)))) if j.size else 0.0)
            obs.update(zip(self.lam_names, vals[self.lam_at].tolist()))   # every joint's multipliers
            if self.joints:
                obs["constraint_residual"] = worst
            for c in self.components:
                obs.update(c.observe(vals[c.q_at], vals[c.v_at], t1,
                                     None if self.x0_values is None else self.x0_values[c.q_at],
                                     None if self.x0_values is None else self.x0_values[c.v_at], self.times[0]))
            for name, (pc, _) in self.marker_points.items():
                model = pc.point.body.body.model
                x = model.frame(pc.unpack(vals[self.marker_at[name]]), pc.point.offset).x
                for c, value in zip("xyz", x):
                    obs[f"{name}_{c}"] = float(value)
        return self.comm.bcast(obs, root=0) if self.comm.size > 1 else obs


def coupled(columns):
    """The groups of items that share columns, directly or through others (the connected components of
    the graph item - column; `columns[i]`: the columns of item i), each a sorted list of items."""
    parent = list(range(len(columns)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    owner = {}
    for i, cols in enumerate(columns):
        for g in cols:
            if g in owner:
                parent[root(i)] = root(owner[g])
            else:
                owner[g] = i
    groups = {}
    for i in range(len(columns)):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


class Couplings:
    """Several couplings of rodfem/fem/assembly.py as one (the joints' rows and the bodies' contacts)."""

    def __init__(self, parts):
        self.parts = parts
        self.local_rows = all(getattr(p, "local_rows", False) for p in parts)

    def entries(self):
        return [e for p in self.parts for e in p.entries()]

    def update(self, X):
        for p in self.parts:
            p.update(X)

    def residual(self, X, b):
        for p in self.parts:
            p.residual(X, b)

    def jacobian(self, X, A):
        for p in self.parts:
            p.jacobian(X, A)

    def grow(self):
        out = [g() for g in (getattr(p, "grow", None) for p in self.parts) if g is not None]
        out = [e for e in out if e is not None]
        return [x for e in out for x in e] if out else None


class JointRows:
    """The joints' and components' terms of a time step (rodfem/fem/assembly.py's coupling): the
    reactions G(q_{n+1/2})^T lambda on the momentum rows and the velocity-level constraint rows
    (rodfem/core/joints.py, `Joint.step`), the springs' and dampers' forces on the momentum rows
    (rodfem/core/components.py), computed on rank 0 and added at global indices."""

    PAIRS = (("v", "q"), ("v", "lam"), ("lam", "q"), ("lam", "v"), ("lam", "lam"))   # blocks a joint can fill
    COMPONENT_PAIRS = (("v", "q"), ("v", "v"))                                         # and a component

    def __init__(self, points):
        self.points, self.comm = points, points.comm
        # the plain joints, stacked (rodfem/core/joint_batch.py); a subclass with terms of its own
        # (rodfem/analysis/statics.py: the joints at rest) keeps the joint-by-joint loop
        self.batch = points.batch if type(self).update is JointRows.update else None
        self.joints = [j for j in points.joints if self.batch is None or not batchable(j)]   # the others
        self.components = points.components
        # bodies placed whole on ranks: the plain joints on the ranks of their rows (rodfem/core/joint_ranks.py);
        # `local_rows`: no term added to another rank's rows (the assembler skips the exchange of entries)
        self.ranked = points.ranked if self.batch is not None else None
        if self.ranked is not None:
            self.batch = None
        self.local_rows = self.ranked is not None and not self.joints and not self.components
        self._batch_work = 0.0
        self._sums = (0.0, 0.0)   # (work, dissipated) of the last residual, on rank 0: `work`, `dissipated`
        self._terms = []

    def entries(self):
        """(rows, cols) of every entry the joints can fill (the same on every rank)."""
        out = self.batch.entries() if self.batch is not None else []
        if self.ranked is not None and self.ranked.batch is not None:
            out += self.ranked.batch.entries()
        for j in self.joints:
            v, q = j.v_index[j.rows], j.q_index[j.qcols]
            lam = j.lam_index
            # (lam, lam): zeros, but with them PETSc's LU in RCM order finds its pivots for the
            # multipliers (without: a zero pivot and the slower LU of the chain's next stage)
            kinds = {"v": v, "q": q, "lam": lam}
            for r, c in ((kinds[a], kinds[b]) for a, b in self.PAIRS):
                R, C = np.meshgrid(r, c, indexing="ij")
                out.append((R.ravel(), C.ravel()))
        for comp in self.components:
            kinds = {"v": comp.v_index[comp.rows], "q": comp.q_index[comp.qcols]}
            for r, c in ((kinds[a], kinds[b]) for a, b in self.COMPONENT_PAIRS):
                R, C = np.meshgrid(r, c, indexing="ij")
                out.append((R.ravel(), C.ravel()))
        return out

    def update(self, X):
        """The joints' terms at the iterate X (rank 0; nothing elsewhere; the ranked joints on their ranks)."""
        self._terms, self._batch_work = [], 0.0
        if self.ranked is not None:
            t0, t1, h = self.points.times
            self._batch_work = self.ranked.update(X, h, t0, t1)
            if self.local_rows:
                return
        vals = self.points.values(X)
        if self.comm.rank == 0:
            v0 = self.points.x0_values
            t0, t1, h = self.points.times
            if self.batch is not None:
                self._batch_work = self.batch.update(v0, vals, h, t0, t1)
            for j in self.joints:
                self._terms.append((j, *self.terms(j, v0, vals, h, t0, t1), 0.0))
            for c in self.components:
                r_v, dr_dq, dr_dv, work, lost = c.step(v0[c.q_at], vals[c.q_at], v0[c.v_at], vals[c.v_at], h, t0, t1)
                self._terms.append((c, r_v, np.zeros(0), (("v", "q", dr_dq), ("v", "v", dr_dv)), work, lost))

    def terms(self, j, v0, v1, h, t0, t1):
        """(r_v, r_lam, {(rows, cols): block}, work) of joint j."""
        r_v, r_lam, drv_dq, drv_dl, drl_dq, drl_dv, work = j.step(
            v0[j.q_at], v1[j.q_at], v0[j.v_at], v1[j.v_at], v1[j.lam_at], h, t0, t1)
        return r_v, r_lam, (("v", "q", drv_dq), ("v", "lam", drv_dl), ("lam", "q", drl_dq), ("lam", "v", drl_dv)), work

    def residual(self, X, b):
        work, lost = self._batch_work, 0.0
        if self.batch is not None and self.comm.rank == 0:
            self.batch.residual(b)
        if self.ranked is not None:
            self.ranked.residual(b.getArray())
        for j, r_v, r_lam, _, w, d in self._terms:
            b.setValues(j.v_index[j.rows].astype(PETSc.IntType), np.ascontiguousarray(r_v[j.rows]),
                        addv=PETSc.InsertMode.ADD)
            if len(r_lam):
                b.setValues(j.lam_index.astype(PETSc.IntType), np.ascontiguousarray(r_lam), addv=PETSc.InsertMode.ADD)
            work += w
            lost += d
        self._sums = (work, lost)

    def _shared_sums(self):
        """(work, dissipated) of the last residual, the same on every rank (collective: read by the time
        loop once a step, not at every residual)."""
        if self.comm.size == 1:
            return self._sums
        if self.ranked is not None:   # (each rank its joints' work)
            return tuple(self.comm.allreduce(np.array(self._sums), op=MPI.SUM).tolist())
        return self.comm.bcast(self._sums, root=0)

    @property
    def work(self):
        """The driven joints' and the servos' supplied work of the last step (collective)."""
        return self._shared_sums()[0]

    @property
    def dissipated(self):
        """The dampers' dissipated energy of the last step (collective)."""
        return self._shared_sums()[1]

    def jacobian(self, X, A):
        if self.batch is not None and self.comm.rank == 0:
            self.batch.jacobian(A)
        if self.ranked is not None:
            self.ranked.jacobian(A)
        for j, _, _, blocks, _, _ in self._terms:
            index = {"v": (j.v_index, j.rows), "q": (j.q_index, j.qcols), "lam": (j.lam_index, list(range(len(j.lam_index))))}
            for rk, ck, block in blocks:
                (r_idx, r_sel), (c_idx, c_sel) = index[rk], index[ck]
                if len(r_sel) and len(c_sel):
                    _add(A, r_idx[list(r_sel)], c_idx[list(c_sel)], block[np.ix_(list(r_sel), list(c_sel))])


def _add(A, rows, cols, values):
    """A[rows, cols] += values (PETSc reads the values row by row: make them C-contiguous)."""
    A.setValues(np.asarray(rows, dtype=PETSc.IntType), np.asarray(cols, dtype=PETSc.IntType),
                np.ascontiguousarray(values, dtype=PETSc.ScalarType), addv=PETSc.InsertMode.ADD)


def ground_frame(point, dim):
    """The fixed Frame of a ground point in `dim` dimensions."""
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
    key = (point.where, tuple(model.kinematics.items())) if point.where != "node" else None
    known = S.__dict__.setdefault("_point_dofs", {})   # (bodies sharing a state space: found once per end)
    found = known.get(key) if key is not None else None
    if found is None:
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
        found = (q_dofs, v_dofs, layout)
        if key is not None:
            known[key] = found
    q_dofs, v_dofs, layout = found
    pc = PointCoordinates(point, np.array(q_dofs), np.array(v_dofs), layout)
    # q(0) from the owning rank
    nloc = S.V.dofmap.index_map.size_local * S.V.dofmap.index_map_bs
    vals = np.full(pc.size, -np.inf)
    for i, d in enumerate(pc.q_dofs):
        if 0 <= d < nloc:
            vals[i] = body.x0.x.array[d]
    pc._values[0] = allreduce_max(comm, vals)
    return pc


