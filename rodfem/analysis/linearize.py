"""The linearized port-Hamiltonian model about a state, as sparse matrices; natural modes.

The discrete model of one step is E (x_{n+1} - x_n)/h = f(x_{n+1/2}, u); its
time-continuous form E x' = f(x, u) is linearized about a state x* (the
initial state or a static equilibrium, rodfem/analysis/statics.py) and inputs u*:

    E dx' = A dx + B du,        dy = C dx,        f0 = f(x*, u*) (zero at an equilibrium)

E = dF/d(x') and A = -dF/dx come from the model's own residual (a `RestStep`
whose rates are a separate field), B = -dF/du from the loads' input maps, C
from their outputs y = B(x)^T z.  The supported dofs (Dirichlet rows) are
removed.  With the constraints kept (rod orthonormality, zero compliances,
massless directors) E is singular: the model is a port-Hamiltonian DAE.

Port-Hamiltonian form (descriptor form of Beattie, Mehrmann, Xu, Zwart 2018):

    E dx' = (J - R) Q dx + B du,    dy = B^T Q dx,    H_lin = 1/2 dx^T E^T Q dx,
    J = -J^T,  R = R^T >= 0,  E^T Q = Q^T E >= 0

with z = Q dx the co-energy (effort) variables, found field by field:
velocities, stresses of the compliance form and multipliers are their own
efforts; a strain s has z = W''(s) s, i.e. Q_ss = M_s^{-1} Hess_ss (the
strain's mass matrix and the Hessian of H); a field with E = 0
(multipliers, constrained stresses, massless velocities) has Q = I.  The
positions q (pairs q' = v of model.kinematics) are not in H; about a
pre-stressed state (hanging cable, loaded beam) their columns of A are the
geometric stiffness, which becomes the Q_qq that makes A = (J - R) Q
(E^T Q restricted to q is that stiffness, symmetric for conservative loads;
positive about unstressed states and states in tension, indefinite under a
compressive or bending pre-stress; `checks` reports the residual
|A - (J - R) Q|, the asymmetry of E^T Q and |R|).  An algebraic row (E = 0:
a constraint) may be written with either sign; the rows of the models'
constraints (+G w, the transpose of the reactions +G^T lambda) are negated
in A and B so that J comes out skew (`checks['rows_negated']`).  `Hess` is
the plain Hessian of H at x* (without the geometric stiffness).  The
decomposition assumes x* at rest (an equilibrium, or the rest state of a
scene); about a moving state (an initial spin) the rows that depend on the
velocities are not of that form and `checks['ph_residual']` says how much.

Modes: the nonzero eigenvalues of the pencil (A, E) are +-i omega.  The rate
form also has one zero eigenvalue per strain (the compatibility invariants
of the rate rows, e.g. C_N N - Pi Gamma(q)), which would swamp a
shift-invert solver; so modes use the pencil (A_m, E_m) of the same model
with the total-form rows of statics in place of the rate rows (strains
algebraic: E_m = 0 on them; constraints on position level): the same
nonzero spectrum without those zeros.  Solved (rodfem/la/pencil.py) with
scipy's dense QZ for at most `DENSE_MAX` states or without slepc4py, else
with SLEPc: Krylov-Schur on (A_m - sigma E_m)^-1 E_m, sigma > 0, for the
eigenvalues of largest imaginary part, i.e. the oscillations, which neither
the infinite eigenvalues of the constraints nor the real ones (a mechanism's
zeros, the relaxation cluster of a viscoelastic model) can crowd out.  Every
returned pair is verified by its residuals; a SLEPc result that is not is
replaced by the dense one up to `DENSE_FALLBACK_MAX` states, else refused.

Serial only (the exported matrices are assembled on one rank).  Systems: the bodies' blocks
and the joints' rows (module `Linearization`); a joint's drive is not an input of the linear model.

Components (rodfem/core/components.py, `System.connect`), at the state and the time t of the
linearization (a timed energy psi(xi, t), e.g. a PD set point, and a control law are read at t):

* a spring V = psi(xi(q)) adds its force G^T psi' to the momentum rows and to the stiffness (the
  columns q of A, hence Q_qq) and to Hess its Hessian G^T psi''(xi) G + sum_k psi'_k(xi) Q_k: its
  own stiffness and the geometric stiffness of its pre-stress (a taut spring's transverse
  stiffness T / l);
* a damper adds eta(xi) G^T G to the velocity columns of A: since Q = I on the velocities, it
  lands in R (symmetric, >= 0).  Only eta's value at the point matters about a rest state (its
  force vanishes there with the velocity);
* a control law u = law(t, xi, xi') (acting as -G^T u) enters A through its linearization
  K = -du/dxi (a stiffness) and D = -du/dxi' (a damping), by differences.  A law is not port-
  Hamiltonian in general: only when K is symmetric and D + D^T >= 0 is it a virtual spring and
  damping injection (then A = (J - R) Q with R >= 0, E^T Q symmetric); otherwise A still holds the
  true linearization but not in that form: `checks['passive']` is False, `checks['not_passive']`
  names the laws, `feedback` holds each law's K, D and verdict (`EtQ_asymmetry` shows a
  non-symmetric K; a negative D, R's indefinite part).
"""
import numpy as np
import scipy.sparse as sp
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc

from rodfem.analysis.statics import RestStep, refuse_servos, rest_form
from rodfem.errors import ParameterError
from rodfem.fem.jit import compile_forms
from rodfem.la.pencil import SHIFT, NotVerified, Pencil, SingularPencil, dense_modes, slepc_modes

DENSE_MAX = 1500            # auto: scipy's dense QZ up to this many states, SLEPc above
DENSE_FALLBACK_MAX = 2000   # a SLEPc result that is not verified: dense QZ up to this many states (~80 s here), else refused


def _csr(A):
    """A PETSc matrix as a scipy CSR matrix (serial)."""
    indptr, indices, data = A.getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=A.getSize())


def _matrix(form):
    A = fpetsc.assemble_matrix(form)
    A.assemble()
    M = _csr(A)
    A.destroy()
    return M


def _vector(form):
    b = fpetsc.assemble_vector(form)
    b.ghostUpdate(addv=__import__("petsc4py").PETSc.InsertMode.ADD, mode=__import__("petsc4py").PETSc.ScatterMode.REVERSE)
    out = b.getArray().copy()
    b.destroy()
    return out


def _body_fields(body):
    """(field name, component, s) of every dof of a body's space (its local numbering)."""
    S = body.space
    n = S.V.dofmap.index_map.size_local * S.V.dofmap.index_map_bs
    field = np.empty(n, dtype=object)
    comp = np.zeros(n, dtype=int)
    coord = np.zeros(n)
    for fld in S.fields:
        if body.rigid:   # one cell: one dof per component (RigidSpace collapses nothing)
            dofs = np.asarray(S.field_dofs(fld.name))
            field[dofs], comp[dofs], coord[dofs] = fld.name, np.arange(len(dofs)), 0.5
            continue
        Vi, dofs = S.collapse(fld.name)
        bs = Vi.dofmap.index_map_bs
        xs = Vi.tabulate_dof_coordinates()[:, 0]
        dofs = np.asarray(dofs)
        ok = dofs < n
        k = np.arange(len(dofs))
        field[dofs[ok]] = fld.name
        comp[dofs[ok]] = (k % bs)[ok]
        coord[dofs[ok]] = xs[k // bs][ok]
    return field, comp, coord


class Linearization:
    """The linear model of a Problem or a System about its current state x_n (inputs as they are
    set now, e.g. by a static solve); `reference`: the state of the total-form rows (a Function,
    or for a System a dict body name -> Function; default the initial state).

    A System's state is its bodies' dofs in the order of the bodies, then the joints'
    multipliers; the joints add their reactions G(q)^T lambda to the momentum rows and their
    rows G(q) v (rate form; E = 0) or g(q) - g_p (the pencil of modes); springs, dampers and
    control laws their linearized forces (see the module docstring), read at time `t` (default:
    the time of the last static solve or time step, else the problem's t)."""

    def __init__(self, problem, reference=None, t=None):
        if problem.comm.size > 1:
            raise ParameterError("linearize and modes run on one process (no mpirun)")
        refuse_servos(problem, "linearize and modes")
        if getattr(problem, "contacts", None):
            raise ParameterError("linearize and modes do not take contact between bodies "
                                 f"({', '.join(c[3] for c in problem.contacts)}): its penalty is not smooth at rest")
        self.problem = problem
        self.system = problem.named_bodies
        problem.build()
        points = getattr(problem, "points", None)
        if t is None:   # the time of the last static solve or time step (the state's), else the problem's
            t = points.times[1] if points is not None and points.x0_values is not None else getattr(problem, "t", 0.0)
        self.t = float(t)
        bodies = problem.body_items()
        parts = []
        for name, body in bodies:
            ref = reference.get(name) if isinstance(reference, dict) else reference
            parts.append(self._body(name, body, ref if ref is not None else body.state0))
        self.X = parts[0]["X"] if not self.system else None
        sizes = [p["n"] for p in parts]
        n_lam = problem.layout.n_multipliers
        full = {}
        for k in ("E", "A", "Em", "Am", "Hess"):
            blocks = [p[k] for p in parts] + ([sp.csr_matrix((n_lam, n_lam))] if n_lam else [])
            full[k] = sp.lil_matrix(sp.block_diag(blocks, format="csr"))
        f0 = np.concatenate([p["f0"] for p in parts] + [np.zeros(n_lam)])
        N = f0.size
        Bcols = [np.concatenate([p["Bcols"][j] if i == b else np.zeros(sizes[i]) for i in range(len(parts))]
                                + [np.zeros(n_lam)]) for b, p in enumerate(parts) for j in range(len(p["Bcols"]))]
        Crows = [np.concatenate([p["Crows"][j] if i == b else np.zeros(sizes[i]) for i in range(len(parts))]
                                + [np.zeros(n_lam)]) for b, p in enumerate(parts) for j in range(len(p["Crows"]))]
        self.inputs = [(f"{p['name']}.{x}" if self.system else x) for p in parts for x in p["inputs"]]
        if self.system and self.problem.joints:
            self._joints(full, f0)
        self.feedback = {}
        if self.system and getattr(self.problem, "components", None):
            self._components(full, f0)
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        self.free = np.concatenate([offsets[i] + p["free"] for i, p in enumerate(parts)]
                                   + [offsets[-1] + np.arange(n_lam)]).astype(int)
        f = self.free
        self.E, self.A, self.Em, self.Am, self.Hess = (sp.csr_matrix(full[k])[f][:, f].tocsr()
                                                      for k in ("E", "A", "Em", "Am", "Hess"))
        self.f0 = f0[f]
        self.B = sp.csr_matrix(np.column_stack(Bcols)[f]) if Bcols else sp.csr_matrix((len(f), 0))
        self.C = sp.csr_matrix(np.vstack(Crows)[:, f]) if Crows else sp.csr_matrix((0, len(f)))
        states = []
        for p in parts:
            states += [((f"{p['name']}.{fl}" if self.system else fl), c, x, k) for fl, c, x, k in p["states"]]
        states += [("joints.lambda", i, 0.0, "other") for i in range(n_lam)]
        self.states = [states[i] for i in f] if len(states) == N else states
        self.parts, self.offsets = parts, offsets
        self.J, self.R, self.Q, self.checks = ph_form(self)

    def _body(self, name, body, ref):
        """The matrices of one body (its local numbering, all dofs) at its state x_n."""
        S, model = body.space, body.model
        X, Xdot = fem.Function(S.V), fem.Function(S.V)
        X.x.array[:] = body.x0.x.array
        F_rate = rest_form(body, X, ref, rates=Xdot, total=False)
        F_tot = rest_form(body, X, ref, rates=Xdot, total=True)
        H = model.hamiltonian(S.split(X), body.dx, body.ds)
        step = RestStep(S.split(X))
        test = S.split(ufl.TestFunction(S.V))
        forms = {"E": ufl.derivative(F_rate, Xdot), "A": -ufl.derivative(F_rate, X),
                 "Em": ufl.derivative(F_tot, Xdot), "Am": -ufl.derivative(F_tot, X),
                 "Hess": ufl.derivative(ufl.derivative(H, X), X), "f0": -F_rate}
        for k, load in enumerate(body.loads):
            forms[f"B{k}"] = -load.input_map(step, test, body.dx, body.ds)
            forms[f"C{k}"] = ufl.derivative(load.power(step, body.dx, body.ds), X)
        c = compile_forms(forms)
        out = {k: _matrix(c[k]) for k in ("E", "A", "Em", "Am", "Hess")}
        out["f0"] = _vector(c["f0"])
        out["Bcols"], out["Crows"], out["inputs"] = [], [], []
        for k, load in enumerate(body.loads):
            saved = np.array(load.constant.value, dtype=float, copy=True)
            for j in range(saved.size):
                e = np.zeros(saved.size)
                e[j] = 1.0
                load.constant.value = e.reshape(saved.shape)
                out["Bcols"].append(_vector(c[f"B{k}"]))
                out["Crows"].append(_vector(c[f"C{k}"]))
                out["inputs"].append(f"{load.name}[{j}]" if saved.size > 1 else load.name)
            load.constant.value = saved
        n = S.V.dofmap.index_map.size_local * S.V.dofmap.index_map_bs
        fixed = np.unique(np.concatenate([bc.dof_indices()[0] for bc in body.bcs])) if body.bcs else np.zeros(0, int)
        field, comp, coord = _body_fields(body)
        kin = getattr(model, "kinematics", {})
        kinds = {q: "position" for q in kin}
        kinds.update({v: "velocity" for v in kin.values()})
        out.update(name=name, body=body, X=X, n=n, free=np.setdiff1d(np.arange(n), fixed),
                   states=[(field[i], int(comp[i]), float(coord[i]), kinds.get(field[i], "other")) for i in range(n)])
        return out

    def _joints(self, full, f0):
        """The joints' rows and reactions at the System's state (serial: block indices = global)."""
        x = self.problem.X0.getArray(readonly=True)
        for j in self.problem.joints:
            q, v, lam = x[j.q_index], x[j.v_index], x[j.lam_index]
            G = np.einsum("kij,j->ki", j.Q, q) + j.c
            g = 0.5 * np.einsum("i,kij,j->k", q, j.Q, q) + j.c @ q + j.e
            fixed = self.problem.points.fixed
            rows = [k for k, i in enumerate(j.v_index) if int(i) not in fixed]
            vi, qi, li = j.v_index, j.q_index, j.lam_index
            lamQ = np.einsum("k,kij->ij", lam, j.Q)
            for key in ("A", "Am"):
                M = full[key]
                for r in rows:
                    for cq in range(len(qi)):
                        M[vi[r], qi[cq]] -= lamQ[r, cq]
                    for k in range(len(li)):
                        M[vi[r], li[k]] -= G[k, r]
            Qv = np.einsum("kij,j->ki", j.Q, v)
            for k in range(len(li)):
                for c_ in range(len(vi)):
                    full["A"][li[k], vi[c_]] -= G[k, c_]        # rate rows: G(q) v
                for c_ in range(len(qi)):
                    full["A"][li[k], qi[c_]] -= Qv[k, c_]
                    full["Am"][li[k], qi[c_]] -= G[k, c_]       # position rows: g(q) - g_p
            for r in rows:
                f0[vi[r]] -= G[:, r] @ lam
            f0[li] -= G @ v
            self.joint_gap = max(getattr(self, "joint_gap", 0.0), float(np.max(np.abs(g))) if len(g) else 0.0)

    def _components(self, full, f0):
        """The springs', dampers' and control laws' terms at the System's state and time `t`
        (rodfem/core/components.py, `linear`): -dr_v/dq and -dr_v/dv added to the momentum rows of
        A and A_modes (the same rows in both), a spring's Hessian of V to Hess, -r_v to f0.  A control
        law's linearization is recorded in `feedback` (name -> its stiffness K = -du/dxi, damping
        D = -du/dxi' and whether they make it a passive element); see `ph_form`."""
        x = self.problem.X0.getArray(readonly=True)
        rows, cols, values, hrows, hcols, hvalues = [], [], [], [], [], []

        def add(r_idx, c_idx, block, into):
            R, C = np.meshgrid(r_idx, c_idx, indexing="ij")
            into[0].append(R.ravel())
            into[1].append(C.ravel())
            into[2].append(np.asarray(block).ravel())
        for c in self.problem.components:
            q, v = x[c.q_index], x[c.v_index]
            terms = c.linear(q, v, self.t)
            mine = list(c.rows)          # the momentum rows not fixed by supports
            vi = c.v_index[mine]
            add(vi, c.q_index, -terms["dq"][mine], (rows, cols, values))
            add(vi, c.v_index, -terms["dv"][mine], (rows, cols, values))
            f0[vi] -= terms["force"][mine]
            if terms["hessian"] is not None:
                add(c.q_index, c.q_index, terms["hessian"], (hrows, hcols, hvalues))
            if "stiffness" in terms:
                self.feedback[c.name] = _passivity(terms["stiffness"], terms["damping"])
        N = f0.size
        for keys, (r, c_, val) in ((("A", "Am"), (rows, cols, values)), (("Hess",), (hrows, hcols, hvalues))):
            if not r:
                continue
            M = sp.csr_matrix((np.concatenate(val), (np.concatenate(r), np.concatenate(c_))), shape=(N, N))
            for key in keys:
                full[key] = sp.lil_matrix(sp.csr_matrix(full[key]) + M)

    def groups(self):
        """{(field, component): indices into the retained dofs}."""
        out = {}
        for i, (name, c, _, _) in enumerate(self.states):
            out.setdefault((name, c), []).append(i)
        return {k: np.array(v) for k, v in out.items()}

    # -- export ----------------------------------------------------------------------
    def matrices(self):
        return {"E": self.E, "J": self.J, "R": self.R, "Q": self.Q, "B": self.B, "C": self.C,
                "A": self.A, "Hess": self.Hess, "E_modes": self.Em, "A_modes": self.Am}

    def write(self, out, extra=None):
        """E.npz, J.npz, ... (scipy.sparse.save_npz), linear.mat (MATLAB, all matrices, f0 and the
        state description), states.csv, linear.json."""
        import json
        import os

        import scipy.io
        os.makedirs(out, exist_ok=True)
        mats = {k: sp.csr_matrix(M) for k, M in self.matrices().items()}
        for M in mats.values():
            M.eliminate_zeros()
        for k, M in mats.items():
            sp.save_npz(os.path.join(out, f"{k}.npz"), sp.csr_matrix(M))
        np.save(os.path.join(out, "f0.npy"), self.f0)
        with open(os.path.join(out, "states.csv"), "w") as fh:
            fh.write("index,field,component,s,kind\n")
            for i, (name, c, s, kind) in enumerate(self.states):
                fh.write(f"{i},{name},{c},{s!r},{kind}\n")
        scipy.io.savemat(os.path.join(out, "linear.mat"),
                         {**{k: sp.csc_matrix(M) for k, M in mats.items()}, "f0": self.f0[:, None],
                          "state_field": np.array([s[0] for s in self.states], dtype=object),
                          "state_component": np.array([s[1] for s in self.states], dtype=float),
                          "state_s": np.array([s[2] for s in self.states]),
                          "inputs": np.array(self.inputs, dtype=object)})
        info = {"n_states": len(self.states), "n_inputs": self.B.shape[1], "inputs": self.inputs,
                "sizes": {k: list(M.shape) for k, M in mats.items()},
                "nnz": {k: int(sp.csr_matrix(M).nnz) for k, M in mats.items()},
                "rank_E": None, "drift_norm": float(np.linalg.norm(self.f0)), "checks": self.checks,
                "fields": sorted({s[0] for s in self.states}),
                **({"feedback": self.feedback} if getattr(self, "feedback", None) else {}), **(extra or {})}
        with open(os.path.join(out, "linear.json"), "w") as fh:
            json.dump(info, fh, indent=2, default=float)
        return info


def _passivity(K, D):
    """A control law's linearization u = -K dxi - D dxi': passive (a port-Hamiltonian element: a
    virtual spring and damping injection) when K = K^T and D + D^T >= 0 (to 1e-8 of their size)."""
    scale = max(float(np.max(np.abs(K))), float(np.max(np.abs(D))), 1e-300)
    asym = float(np.max(np.abs(K - K.T))) / scale
    lowest = float(np.min(np.linalg.eigvalsh(0.5 * (D + D.T)))) / scale
    return {"stiffness": K.tolist(), "damping": D.tolist(), "stiffness_asymmetry": asym,
            "damping_lowest_eigenvalue": lowest * scale, "passive": bool(asym <= 1e-8 and lowest >= -1e-8)}


def _norm(M):
    M = sp.csr_matrix(M)
    return float(np.sqrt(M.multiply(M).sum())) if M.nnz else 0.0


def ph_form(lin):
    """(J, R, Q, checks) with A = (J - R) Q on the retained dofs (see the module docstring)."""
    from scipy.sparse.linalg import spsolve
    E, A, Hess = lin.E.tocsc(), lin.A.tocsc(), lin.Hess.tocsc()
    n = E.shape[0]
    groups = lin.groups()
    kinds = {name: kind for name, _, _, kind in lin.states}
    Q = sp.lil_matrix((n, n))
    Qinv = sp.lil_matrix((n, n))
    efforts, positions, algebraic = [], [], []
    for (name, _), g in groups.items():
        if kinds[name] == "position":
            positions.append(g)
            continue
        Eg, Hg = E[g][:, g], Hess[g][:, g]
        if _norm(Eg) == 0.0:            # multipliers, constrained stresses, massless velocities: z = x
            Qg, Qgi = sp.identity(len(g)), sp.identity(len(g))
            if kinds[name] != "velocity":   # a massless velocity's row is a balance: its sign is fixed
                algebraic.append((name, g))
        else:
            Qg = sp.csr_matrix(spsolve(Eg.tocsc(), Hg.tocsc()))
            if _norm(Hg) == 0.0:
                raise ParameterError(f"field {name} has E != 0 but no energy: cannot form Q")
            Qgi = sp.csr_matrix(spsolve(Hg.tocsc(), Eg.tocsc()))
        Q[np.ix_(g, g)] = Qg
        Qinv[np.ix_(g, g)] = Qgi
        efforts.append(g)
    S = np.concatenate(efforts) if efforts else np.zeros(0, int)
    P = np.concatenate(positions) if positions else np.zeros(0, int)
    Qinv = Qinv.tocsc()
    JR = sp.lil_matrix((n, n))
    JR[:, S] = (A[:, S] @ Qinv[S][:, S]).tolil()
    if len(P):
        JR[:, P] = -(JR[P, :].T)                                  # skew completion: J_vq = -J_qv^T
        JR = JR.tocsc()
        JP = JR[:, P]
        rows = np.unique(JP.nonzero()[0])
        if len(rows) == len(P):
            Q[np.ix_(P, P)] = sp.csr_matrix(spsolve(JP[rows].tocsc(), A[rows][:, P].tocsc()))
    JR = sp.csr_matrix(JR)
    # An algebraic row (E = 0) may be written with either sign (0 = G w or 0 = -G w): take the one
    # that makes the interconnection skew (the rod's and rigid body's constraint rows are written
    # +G w, the transpose of their reactions +G^T lambda); A, B and f0 are negated there too.
    negated = []
    for name, g in algebraic:
        rows, cols = JR[g, :], JR[:, g].T
        if _norm(rows - cols) < _norm(rows + cols):
            D = sp.identity(n, format="lil")
            D[g, g] = -1.0
            D = D.tocsr()
            JR = D @ JR
            lin.A, lin.B, lin.E = (D @ lin.A).tocsr(), (D @ lin.B).tocsr(), (D @ lin.E).tocsr()
            lin.f0 = D @ lin.f0
            negated.append(name)
    A = lin.A.tocsc()
    Q = Q.tocsr()
    J = 0.5 * (JR - JR.T)
    R = -0.5 * (JR + JR.T)
    EQ = (E.T @ Q).tocsr()
    nA = _norm(A) or 1.0
    nA_max = abs(A).max() or 1.0
    checks = {"ph_residual": _norm(A - (J - R) @ Q) / nA,
              "EtQ_asymmetry": _norm(EQ - EQ.T) / (_norm(EQ) or 1.0),
              "R_norm": _norm(R) / nA,
              "output_map_residual": _norm(lin.C - (lin.B.T @ Q)) / (_norm(lin.C) or 1.0),
              "rows_negated": sorted(set(negated)),
              "passive": all(f["passive"] for f in getattr(lin, "feedback", {}).values()),
              "not_passive": sorted(name for name, f in getattr(lin, "feedback", {}).items() if not f["passive"])}
    J, R = (_clean(M, nA_max) for M in (J, R))
    Q = _clean(Q, abs(Q).max() or 1.0)
    return J, R, Q, checks


def _clean(M, scale):
    """M without the round-off entries (below 1e-15 of `scale`) left by the splitting."""
    M = sp.csr_matrix(M, copy=True)
    M.data[np.abs(M.data) < 1e-15 * scale] = 0.0
    M.eliminate_zeros()
    return M


# -- natural modes ----------------------------------------------------------------------------

def natural_modes(lin, k=6, solver="auto", target=SHIFT):
    """The k lowest natural angular frequencies omega (rad/s: the imaginary parts of the eigenvalues
    s = -zeta |s| + i omega of A_m x = s E_m x, the damped frequencies of a dissipating model) and mode
    vectors (complex, retained dofs).  Returns (omega, vectors, solver used).

    Every pair is verified (rodfem/la/pencil.py: backward error and the test that rejects the
    roundoff images of infinite eigenvalues); no unverified pair is returned.  'dense': QZ of the
    whole pencil; 'slepc': Krylov-Schur on (A_m - target E_m)^-1 E_m (target: a real shift > 0 in
    rad/s); 'auto': dense up to DENSE_MAX states.  A SLEPc result that cannot be certified is
    replaced by the dense one up to DENSE_FALLBACK_MAX states, else refused (ParameterError).
    `lin.damping` holds zeta = -Re s / |s| (0 without dissipation), `lin.modes_info` how they were
    found (solver, fallback, residuals, eigenvalue counts, the SLEPc band)."""
    n = lin.Em.shape[0]
    if solver not in ("auto", "dense", "slepc"):
        raise ParameterError(f"modes solver must be one of auto, dense, slepc (got {solver!r})")
    if not (np.isfinite(target) and target > 0):
        raise ParameterError(f"the modes shift (target) must be a number > 0 in rad/s (got {target!r})")
    if solver == "slepc" and not _have_slepc():
        raise ParameterError("--solver slepc needs slepc4py (not installed); use --solver dense")
    if solver == "auto":
        solver = "dense" if n <= DENSE_MAX or not _have_slepc() else "slepc"
    p = Pencil(lin.Am, lin.Em)
    modes, fallback = _slepc_or_fallback(p, k, target) if solver == "slepc" else (None, None)
    modes = modes or dense_modes(p, k)
    s = modes.s
    lin.damping = np.maximum(-s.real / np.abs(s), 0.0) if len(s) else np.zeros(0)
    lin.modes_info = dict(modes.info, fallback=fallback, residuals=[float(r) for r in modes.residuals])
    return s.imag, modes.vectors, modes.info["solver"]


def _slepc_or_fallback(p, k, shift):
    """(Modes, None) from SLEPc, or (None, why) if its result is not verified and the dense
    fallback may take the pencil; else ParameterError."""
    try:
        return slepc_modes(p, k, shift), None
    except SingularPencil as e:
        raise ParameterError(f"modes: the pencil (A_modes, E_modes) is singular ({e}): a motion the "
                             "model leaves undetermined (an unconstrained multiplier or a free body)") from None
    except NotVerified as why:
        if p.n > DENSE_FALLBACK_MAX:
            raise ParameterError(f"modes: the SLEPc result is not verified ({why}) and {p.n} states are more than "
                                 f"the dense fallback takes (at most {DENSE_FALLBACK_MAX}); try a smaller "
                                 "--count or fewer elements") from None
        return None, str(why)


def _have_slepc():
    try:
        import slepc4py  # noqa: F401
        return True
    except ImportError:
        return False


def mode_shapes(lin, vectors):
    """Per flexible body: (name, s, reference positions[n, d], [displacement[n, d] per mode]) of the
    centreline, each mode normalised to max |dr| = 1 over all bodies (real: the phase of its
    largest entry removed)."""
    where = {int(d): i for i, d in enumerate(lin.free)}
    bodies, raw = [], []
    for k, part in enumerate(lin.parts):
        body = part["body"]
        if body.rigid:
            continue
        S, pos = body.space, body.model.position
        Vi, dofs = S.collapse(pos)
        bs = Vi.dofmap.index_map_bs
        nloc = Vi.dofmap.index_map.size_local
        s = Vi.tabulate_dof_coordinates()[:nloc, 0]
        order = np.argsort(s)
        dofs = np.asarray(dofs)
        ref = part["X"].x.array[dofs].reshape(-1, bs)[:nloc][order]
        rows = np.array([where.get(int(lin.offsets[k] + d), -1) for d in dofs])
        disp = []
        for m in range(vectors.shape[1]):
            full = np.where(rows >= 0, vectors[np.maximum(rows, 0), m], 0.0)
            disp.append(full.reshape(-1, bs)[:nloc][order])
        bodies.append((part["name"], s[order], ref))
        raw.append(disp)
    shapes = []
    for m in range(vectors.shape[1]):
        allv = np.concatenate([r[m].ravel() for r in raw]) if raw else np.zeros(1)
        big = allv[np.argmax(np.abs(allv))] if allv.size else 0
        per = [(r[m] / big).real if big != 0 else r[m].real for r in raw]
        scale = max((np.max(np.abs(x)) for x in per), default=1.0) or 1.0
        shapes.append([x / scale for x in per])
    return bodies, shapes


def plot_modes(path, bodies, shapes, omega, amplitude=None):
    """The first modes (one panel each): reference centrelines dashed, +- the mode shape."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = len(shapes)
    refs = [b[2] for b in bodies]
    every = np.concatenate(refs)
    L = float(np.max(np.ptp(every, axis=0))) or 1.0
    a = amplitude or 0.1 * L
    d = every.shape[1]
    spread = np.ptp(np.concatenate([every] + [r + a * x for mode in shapes for r, x in zip(refs, mode)]), axis=0)
    ax2 = sorted(np.argsort(spread)[-2:]) if d > 2 else [0, 1]
    fig, axes = plt.subplots(1, max(n, 1), figsize=(3.2 * max(n, 1), 3.4), squeeze=False)
    for k in range(n):
        ax = axes[0, k]
        for b, (ref, x) in enumerate(zip(refs, shapes[k])):
            ax.plot(ref[:, ax2[0]], ref[:, ax2[1]], "k--", lw=1)
            for sign, style in ((1, "-"), (-1, ":")):
                y = ref + sign * a * x
                ax.plot(y[:, ax2[0]], y[:, ax2[1]], style, color=f"C{b}", lw=1.5)
        ax.set_title(f"mode {k + 1}: {omega[k] / (2 * np.pi):.4g} Hz")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("xyz"[ax2[0]])
        ax.set_ylabel("xyz"[ax2[1]])
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
