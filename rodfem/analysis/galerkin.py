"""The nonlinear reduced model: a structure-preserving POD-Galerkin projection of the step residual.

The full step (rodfem/core/integrators.py) is the weak form F(x_n, x_{n+1}) = 0 of

    E (x_{n+1} - x_n)/h = J(x_{n+1/2}) z_{n,n+1} + B u_{n+1/2},

whose energy balance H(x_{n+1}) - H(x_n) = h y.u follows by testing with the step's efforts z
(the velocity rows with the midpoint velocities, the strain rows with the efforts of the energy).
The reduced model keeps that proof.  The state is split into blocks (read off the model):

* configuration q and velocity v (the pairs of ``model.kinematics``, e.g. r -> v, phi -> omega):
  ONE basis Phi for both, q = q_ref + Phi a, v = Phi b (the same basis for the configuration and
  its rate, the cotangent-lift idea of Peng & Mohseni, "Symplectic model reduction of Hamiltonian
  systems", SIAM J. Sci. Comput. 38(1) (2016) A1-A27, doi:10.1137/140978922);
* energy variables e (the keys of ``model.efforts``, e.g. the strains) and their effort fields
  n (its values: algebraic fields holding the L2 projection of the step's effort, e.g. N, M): ONE
  basis Psi for both, e = e_ref + Psi c, n = Psi m.

x_{n+1} = x_ref + V xi_{n+1} with V = blockdiag(Phi, Phi, Psi, Psi) (each block Euclidean-orthonormal),
and the reduced step is the Galerkin projection

    V^T F(x_ref + V xi_n, x_ref + V xi_{n+1}) = 0,

solved by Newton in xi (the reduced Jacobian V^T (dF/dx) V).  Why the energy balance stays exact
(to Newton's tolerance): every test vector of the full proof lies in range(V).  The velocity rows
are tested with v_m = Phi b_m (in range, as v is); the strain rows with the projected effort
n = Psi m (in range); the effort rows int (n - grad W) . tau = 0 with tau = e_{n+1} - e_n = Psi (c_{n+1} - c_n)
(in range), so int n . (e_{n+1} - e_n) = int grad W . (e_{n+1} - e_n) = W_{n+1} - W_n for the
discrete gradient (for the midpoint rule when W is quadratic).  This is the structure-preserving
projection of Chaturantabut, Beattie & Gugercin, "Structure-preserving model reduction for nonlinear
port-Hamiltonian systems", SIAM J. Sci. Comput. 38(5) (2016) B837-B865, doi:10.1137/15M1055085 (POD
bases, the reduced Hamiltonian H_r(xi) = H(x_ref + V xi), the structure operators and the input map
projected so that the reduced model is port-Hamiltonian again), here carried out on the weak form of
the step, block by block, with the full model's discrete gradient restricted to range(V):

    H_r(xi_{n+1}) - H_r(xi_n) = h y_r . u       (y_r = the port's output at the reduced states)

and, with u = 0, H_r is conserved: the reduced model creates no energy (passive).  Besides, the kinematic
rows tested with Phi give a_{n+1} - a_n = h b_m exactly (the shared basis).

The bases are POD (the leading left singular vectors) of snapshots of a training run, per block:
the configuration block of [q_k - q_ref, s v_k], the energy block of [e_k - e_ref, s' n_k] (s, s'
scale the second set to the Frobenius norm of the first), each field of a block weighted by the
inverse of its snapshots' RMS (so that metres, radians and strains weigh alike), then orthonormalized.
x_ref is the first snapshot with its velocities and efforts set to zero (the Dirichlet values stay
in x_ref: the snapshots' deviations, hence the bases, vanish there; fixed supports only).

The energy basis also holds the strain images of the configuration modes (`strain_images`: the energy
variables' increments de_j that the velocity phi_j causes in one step, linearized at x_ref), orthonormalized
with its POD modes.  Without them a configuration mode whose strains the energy basis misses has no
stiffness, and the load drives it freely: on the cantilever at large deflection the POD-only basis with
as many energy as configuration modes had errors of 1.3 (r = 4) and, with half as many, 8 to 95 times the
motion; with the images the error falls with r (benchmarks/nonlinear_reduce.md).  So a block of r
configuration modes gives 2 r unknowns (a, b) and the energy block 2 (r_e + r) (c, m), r_e = r POD modes.

Damping (forms/damping.py: Kelvin-Voigt and Rayleigh): the viscous stress D e_n (D a constant
diagonal of viscosities, e_n = (e_{n+1} - e_n)/h the strain fields' rate) enters the velocity rows; the
full proof tests the strain rows with D e_n.  With e_n in range(Psi) that test vector lies in range(Psi)
when Psi is block-diagonal over the scalar strain components (`split_components`: the basis of each
component's rows of Psi; more energy unknowns), so with damping the energy basis is split, and

    H_r(xi_{n+1}) - H_r(xi_n) + h d_n = h y_r . u,    h d_n = h int e_n . D e_n + h alpha int v_m . M v_m >= 0

exactly (the Rayleigh part, tested with v_m = Phi b_m, needs nothing more).

What is not reduced here: the assembly.  F and dF/dx are assembled at full order every Newton
iteration, so a reduced step costs a full step's assembly plus the projections; only the linear solve
is small (rodfem/analysis/ecsw.py hyper-reduces it).

Scope (ParameterError otherwise): one body (no joints, components, contacts), every field in one of
the four groups above, no dissipation other than Kelvin-Voigt / Rayleigh damping (Maxwell branches'
and friction's viscous efforts are not fields: their test vectors would not lie in range(V)), serial.
"""
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from rodfem.errors import NewtonFailure, ParameterError
from rodfem.nls.newton import DEFAULTS, Solve

ATOL, RTOL, STOL, MAX_IT = (DEFAULTS[k] for k in ("snes_atol", "snes_rtol", "snes_stol", "snes_max_it"))
DROP = 1e-12     # singular values below DROP * the largest are not modes


@dataclass
class Layout:
    """The dof indices (in the system's state vector) of the four groups, each a concatenation over its fields
    (the partner groups in the same order): q <-> v, e <-> n; `fields` the field names per group."""
    q: np.ndarray
    v: np.ndarray
    e: np.ndarray
    n: np.ndarray
    fields: dict
    field_slices: dict = field(default_factory=dict)   # group -> [(field, slice in the group)]
    components: dict = field(default_factory=dict)     # group -> [positions in the group of one scalar component]
    damped: bool = False                               # Kelvin-Voigt / Rayleigh damping (see pod_basis)


def layout(problem) -> Layout:
    """The groups of `problem` (a single-body System) from its model's `kinematics` and `efforts`."""
    if problem.comm.size > 1:
        raise ParameterError("the nonlinear reduced model runs serially (run it without mpirun)")
    problem.build()
    bodies = problem.body_items()
    if len(bodies) != 1 or problem.joints or problem.components or problem.contacts:
        raise ParameterError("nonlinear reduction: one body without joints, components or contacts is needed "
                             f"(the system has {len(bodies)} bodies, {len(problem.joints)} joints, "
                             f"{len(problem.components)} components, {len(problem.contacts)} contacts)")
    _, body = bodies[0]
    model = body.model
    damped = getattr(model, "damping", None) is not None
    if getattr(problem, "dissipates", False) and (getattr(model, "branches", ()) or body.contacts or not damped):
        raise ParameterError("nonlinear reduction: the scene dissipates otherwise than by Kelvin-Voigt or Rayleigh damping "
                             "(Maxwell branches, contact friction): its viscous efforts are not fields, the reduced "
                             "energy balance would not hold")
    kin, eff = dict(getattr(model, "kinematics", {})), dict(getattr(model, "efforts", {}))
    names = body.space.names
    grouped = set(kin) | set(kin.values()) | set(eff) | set(eff.values())
    if not eff:
        raise ParameterError("nonlinear reduction needs the model's efforts as fields (model.efforts, e.g. the "
                             "planar beam at degree >= 2: --set degree=2); this model has none")
    rest = [n for n in names if n not in grouped]
    if rest:
        raise ParameterError(f"nonlinear reduction: the fields {', '.join(rest)} are neither configuration, "
                             "velocity, energy variable nor effort (model.kinematics, model.efforts)")
    groups = {"q": list(kin), "v": list(kin.values()), "e": list(eff), "n": list(eff.values())}
    idx, slices, components = {}, {}, {}
    for g, fields in groups.items():
        parts, at, sl, comps = [], 0, [], []
        for f in fields:
            d = np.asarray(body.space.collapse(f)[1], dtype=np.int64)
            size = body.space.field(f).size   # (the collapsed dofs of a vector field: node by node, its components)
            parts.append(d)
            sl.append((f, slice(at, at + len(d))))
            comps += [at + np.arange(c, len(d), size) for c in range(size)]
            at += len(d)
        idx[g], slices[g], components[g] = np.concatenate(parts), sl, comps
    for a, b in (("q", "v"), ("e", "n")):
        if len(idx[a]) != len(idx[b]):   # pragma: no cover - a model whose partner fields differ in element
            raise ParameterError(f"nonlinear reduction: the fields {groups[a]} and {groups[b]} have different elements")
    return Layout(idx["q"], idx["v"], idx["e"], idx["n"], groups, slices, components,
                  bool(getattr(problem, "dissipates", False)))


def pod(columns, rank, slices):
    """An orthonormal basis of the leading `rank` POD modes of `columns` (rows: the block's dofs), each field's
    rows (`slices`) weighted by the inverse RMS of its entries; also the singular values.  Fewer modes when the
    snapshots span fewer (singular values below DROP of the largest)."""
    w = np.ones(columns.shape[0])
    for _, s in slices:
        rms = np.sqrt(np.mean(columns[s] ** 2)) if columns[s].size else 0.0
        w[s] = 1.0 / rms if rms > 0 else 1.0
    U, sv, _ = np.linalg.svd(w[:, None] * columns, full_matrices=False)
    keep = int(min(rank, np.sum(sv > DROP * (sv[0] if len(sv) else 0.0))))
    if keep < 1:
        raise ParameterError("nonlinear reduction: the training snapshots do not move (no POD modes)")
    Q, _ = np.linalg.qr(U[:, :keep] / w[:, None])
    return Q, sv


@dataclass
class Basis:
    """x = x_ref + V xi: V (n x (2 r_q + 2 r_e)) column blocks [q, v, e, n]; the POD singular values."""
    V: np.ndarray
    x_ref: np.ndarray
    ranks: dict
    singular_values: dict
    layout: Layout

    @property
    def order(self):
        return self.V.shape[1]

    def coordinates(self, x):
        """xi of the full state x (the orthogonal projection: V has orthonormal columns)."""
        return self.V.T @ (np.asarray(x) - self.x_ref)

    def full(self, xi):
        return self.x_ref + self.V @ xi


def strain_images(problem, Phi, lay: Layout, x):
    """The energy variables' increments that the configuration modes Phi cause, linearized at the state x: the
    energy rows' solution de = -J_ee^{-1} J_ev phi_j for the velocity phi_j (J = dF/dx_{n+1} of the step at x;
    scaled to unit norm).  A configuration mode whose increments the energy basis misses would have no stiffness."""
    A = problem.assembler.A
    problem.restore((np.asarray(x, dtype=float), []))     # x_n = x_{n+1} = x (the Jacobian reads both)
    problem.assembler.jacobian(problem.assembler.vector, A)
    indptr, cols, vals = A.getValuesCSR()
    J = sp.csr_matrix((vals, cols, indptr), shape=A.getSize())
    Jee = J[lay.e][:, lay.e].tocsc()
    rhs = -(J[lay.e][:, lay.v] @ Phi)
    de = np.asarray(spla.spsolve(Jee, rhs)).reshape(len(lay.e), -1)
    return de / np.maximum(np.linalg.norm(de, axis=0), 1e-300)


def pod_basis(snapshots, rank, lay: Layout, problem=None, energy_rank=None) -> Basis:
    """The basis of the module docstring from `snapshots` (full states, one per column, the first the initial
    state) with `rank` (>= 1) configuration modes and `energy_rank` (default `rank`) energy POD modes; with
    `problem`, the energy basis also holds the strain images of the configuration modes at the first snapshot
    (`strain_images`)."""
    if not (isinstance(rank, (int, np.integer)) and rank >= 1):
        raise ParameterError(f"--order must be an integer >= 1 (modes per block; got {rank!r})")
    energy_rank = rank if energy_rank is None else energy_rank
    X = np.asarray(snapshots, dtype=float)
    x0 = X[:, 0]

    def block(a, b):
        dev, raw = X[a] - x0[a][:, None], X[b]
        na, nb = np.linalg.norm(dev), np.linalg.norm(raw)
        return np.hstack([dev, raw * (na / nb if nb > 0 and na > 0 else 1.0)])
    Phi, s_q = pod(block(lay.q, lay.v), rank, lay.field_slices["q"])
    Psi, s_e = pod(block(lay.e, lay.n), energy_rank, lay.field_slices["e"])
    if problem is not None:   # the strain images first, then the POD modes they do not span
        U, sv, _ = np.linalg.svd(np.hstack([strain_images(problem, Phi, lay, x0), Psi]), full_matrices=False)
        Psi = U[:, :int(np.sum(sv > 1e-8 * sv[0]))]
    if lay.damped:   # the energy basis component by component: D Psi c in range(Psi) for any constant diagonal D
        Psi = split_components(Psi, lay.components["e"])
    n, rq, re = X.shape[0], Phi.shape[1], Psi.shape[1]
    V = np.zeros((n, 2 * rq + 2 * re))
    V[lay.q, :rq] = Phi
    V[lay.v, rq:2 * rq] = Phi
    V[lay.e, 2 * rq:2 * rq + re] = Psi
    V[lay.n, 2 * rq + re:] = Psi
    x_ref = x0.copy()
    x_ref[lay.v] = 0.0
    x_ref[lay.n] = 0.0
    return Basis(V, x_ref, {"configuration": rq, "energy": re}, {"configuration": s_q, "energy": s_e}, lay)


def split_components(Psi, components):
    """The orthonormal basis of the span of Psi's rows of each scalar component (`components`: their row positions),
    block-diagonal over the components: the span of Psi, and closed under a constant scaling per component."""
    blocks = []
    for rows in components:
        U, sv, _ = np.linalg.svd(Psi[rows], full_matrices=False)
        keep = int(np.sum(sv > 1e-8 * sv[0])) if len(sv) and sv[0] > 0 else 0
        B = np.zeros((Psi.shape[0], keep))
        B[rows] = U[:, :keep]
        blocks.append(B)
    return np.hstack(blocks)


class ReducedSystem:
    """The reduced model of `problem` (a built single-body System) in the basis `basis`, stepped by the time
    loop (rodfem/analysis/timeloop.py: it is a `SteppedSystem`): run(ReducedSystem(problem, basis), dt, t_end)
    gives the history with H_r, supplied, balance_error and the problem's observables at the reduced states.
    It starts at the projection of the problem's current state x_n (`start` = a full state instead).
    `timings`: seconds spent assembling F and dF/dx (full order), projecting, and solving."""

    def __init__(self, problem, basis: Basis, start=None):
        layout(problem)    # the scope checks
        self.problem, self.basis = problem, basis
        self.comm = problem.comm
        self.assembler = problem.assembler
        n = self.assembler.vector.getSize()
        if basis.V.shape[0] != n:
            raise ParameterError(f"nonlinear reduction: the basis has {basis.V.shape[0]} rows, the problem {n} dofs "
                                 "(another mesh or degree than the training run)")
        self.V = basis.V
        self.Vt = sp.csr_matrix(basis.V.T)    # block-sparse: each column lives in one group (V^T (J V): 2x faster)
        x = np.asarray(start if start is not None else problem.snapshot()[0], dtype=float)
        self.xi0 = basis.coordinates(x)
        self.initial_projection_error = float(np.linalg.norm(basis.full(self.xi0) - x) / max(np.linalg.norm(x), 1e-300))
        self.xi1 = self.xi0.copy()
        self.t, self.dt = 0.0, 1.0
        self._b = self.assembler.create_vector()
        self.timings = {"assemble_F": 0.0, "assemble_J": 0.0, "project": 0.0, "solve": 0.0}
        self.iterations = 0
        self._push_x0()

    # -- the state ------------------------------------------------------------------------
    def _push_x0(self):
        """x_n = x_{n+1} = x_ref + V xi_n in the problem's Functions."""
        self.problem.restore((self.basis.full(self.xi0), []))

    def _set_x1(self, xi):
        X = self.assembler.vector
        X.getArray()[:] = self.basis.full(xi)
        self.assembler.update(X)

    def state(self):
        """x_{n+1} = x_ref + V xi_{n+1} (full)."""
        return self.basis.full(self.xi1)

    # -- the time loop's view -------------------------------------------------------------
    def set_step(self, h):
        self.dt = float(h)
        self.problem.set_step(h)

    def set_time(self, t):
        self.problem.set_time(t)

    def predict(self, previous, ratio=1.0):
        self.xi1 = self.xi0.copy() if previous is None else self.xi0 + ratio * (self.xi0 - previous)

    def _residual(self, xi):
        t0 = time.perf_counter()
        self._set_x1(xi)
        self.assembler.residual(self.assembler.vector, self._b)
        t1 = time.perf_counter()
        r = self.Vt @ self._b.getArray(readonly=True)
        self.timings["assemble_F"] += t1 - t0
        self.timings["project"] += time.perf_counter() - t1
        return r

    def _jacobian(self):
        t0 = time.perf_counter()
        A = self.assembler.A
        self.assembler.jacobian(self.assembler.vector, A)
        t1 = time.perf_counter()
        indptr, cols, vals = A.getValuesCSR()
        J = sp.csr_matrix((vals, cols, indptr), shape=A.getSize())
        Jr = self.Vt @ (J @ self.V)
        self.timings["assemble_J"] += t1 - t0
        self.timings["project"] += time.perf_counter() - t1
        return Jr

    def solve(self, step, t):
        """xi_{n+1}: Newton on V^T F(xi) = 0 (the full model's tolerances: |r| <= ATOL, |r| <= RTOL |r_0|, or
        the update |d xi| <= STOL |xi|)."""
        xi = self.xi1.copy()
        r0 = None
        dxi = None
        for it in range(MAX_IT + 1):
            r = self._residual(xi)
            norm = float(np.linalg.norm(r))
            if not np.isfinite(norm):
                raise NewtonFailure(step, t, norm, it, "non-finite reduced residual")
            r0 = norm if r0 is None else r0
            small = dxi is not None and np.linalg.norm(dxi) <= STOL * np.linalg.norm(xi)
            if norm <= ATOL or norm <= RTOL * r0 or small:
                self.xi1 = xi
                self.iterations += it
                return Solve(it, norm)
            if it == MAX_IT:
                break
            Jr = self._jacobian()
            t0 = time.perf_counter()
            try:
                dxi = np.linalg.solve(Jr, -r)
            except np.linalg.LinAlgError:
                raise NewtonFailure(step, t, norm, it, "singular reduced Jacobian") from None
            self.timings["solve"] += time.perf_counter() - t0
            xi = xi + dxi
        self._set_x1(self.xi1)
        raise NewtonFailure(step, t, norm, MAX_IT, "reduced Newton: no convergence")

    def accept(self):
        previous = self.xi0.copy()
        self.xi0 = self.xi1.copy()
        self._push_x0()
        return previous

    def hamiltonian(self):
        """H_r(xi_{n+1}) = H(x_ref + V xi_{n+1})."""
        self._set_x1(self.xi1)
        return self.problem.hamiltonian()

    def supplied_work(self):
        return self.problem.supplied_work()

    @property
    def dissipates(self):
        return bool(getattr(self.problem, "dissipates", False))

    def dissipated_energy(self):
        """h d_n of the step xi_n -> xi_{n+1} (the Kelvin-Voigt / Rayleigh dissipation at the reduced states)."""
        if not self.dissipates:
            return 0.0
        self._set_x1(self.xi1)
        return self.problem.dissipated_energy()

    def observe(self):
        return self.problem.observe()

    def snapshot(self):
        return (self.xi0.copy(), [])

    def restore(self, snapshot):
        self.xi0 = np.asarray(snapshot[0]).copy()
        self.xi1 = self.xi0.copy()
        self._push_x0()
