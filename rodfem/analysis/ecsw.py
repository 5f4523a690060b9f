"""Hyper-reduction of the nonlinear reduced model: Energy-Conserving Sampling and Weighting (ECSW).

The reduced model of rodfem/analysis/galerkin.py solves V^T F(x_ref + V xi_n, x_ref + V xi_{n+1}) = 0,
but assembles F at full order.  The step residual is a sum over the cells e (plus the exterior-facet
terms: the point ports, here the tip load), V^T F = sum_e V_e^T F_e + sum_f V_f^T F_f.  ECSW (Farhat,
Avery, Chapman & Cortial, "Dimensional reduction of nonlinear finite element dynamic models with
finite rotations and energy-based mesh sampling and weighting for computational efficiency",
Int. J. Numer. Meth. Engng. 98(9) (2014) 625-662, doi:10.1002/nme.4668; Farhat, Chapman & Avery,
"Structure-preserving, stability, and accuracy properties of the energy-conserving sampling and
weighting method for the hyper reduction of nonlinear finite element dynamic models",
Int. J. Numer. Meth. Engng. 102 (2015) 1077-1110, doi:10.1002/nme.4820) replaces the sum over
all cells by a weighted sum over a few,

    V^T F_w = sum_{e in sample} w_e V_e^T F_e + sum_f V_f^T F_f,    w_e > 0,

the point ports kept exact.  Since every cell's residual is tested with the same test vectors
(range(V)) and each cell's part of the discrete energy balance holds cell by cell (the effort rows,
the strain rows and the velocity rows of one cell give that cell's W_e(n+1) - W_e(n) and
T_e(n+1) - T_e(n), their skew terms cancel within the cell), the weighted model is the structure-
preserving reduced model of the weighted Hamiltonian H_w = sum_e w_e H_e (+ the facet terms):

    H_w(xi_{n+1}) - H_w(xi_n) = h y.u      exactly (to Newton's tolerance),

and with u = 0 H_w is conserved; w_e > 0 keeps H_w >= 0 (the model stays passive).  The supplied
work is the same weighted sum of the work form (the tip load: a facet term, exact).

Training (`train`): at `snapshots` states of the training run, projected on the basis
(xi_k = V^T (x_k - x_ref), the states the reduced model visits), each cell's contributions

    g_e = [ V_e^T F_e(xi_{k-1}, xi_k) ;  V_e^T F_e(xi_k, xi_k) ;  H_e(xi_k) ]

(the step residual; its instantaneous part J z at x_n = x_{n+1}, the rates removed, so that the
inertia and the forces are fitted apart: their sum nearly cancels; and the cell's energy), each
row scaled by the inverse norm of its cells' contributions (every reduced equation, in its own
units, weighs alike), are the columns of G; an equation whose contributions vanish identically
(below VANISHING of the block's largest: the kinematic rows (q_{k} - q_{k-1})/h - v_m at the
projected states, zero in every cell since q and v share their basis) is left out, its round-off
would otherwise be scaled up to noise of the size of the others.  The weights solve

    min |w|_0   subject to   |G w - G 1| <= tol |G 1|,   w >= 0,

approximately, by the active-set non-negative least squares of Lawson & Hanson (Solving Least
Squares Problems, Prentice-Hall 1974, ch. 23) stopped as soon as the tolerance is met (each step
adds the cell of the largest gradient; the stopping test on the residual, as in Farhat et al. 2015).
The sample is the cells with w_e > 0.

Online (`HyperReducedSystem`): the residual, the Jacobian V^T J V, H_w, the supplied work and the
facet-only outputs (the tip position) are evaluated on the sampled cells and the facets only, by
rodfem/fem/sampled.py; nothing of the full size is assembled.  An output that is a cell integral
(a mean position) is evaluated at full order from x_ref + V xi (documented cost).
"""
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from rodfem.analysis.galerkin import ATOL, MAX_IT, RTOL, STOL, Basis, ReducedSystem, layout
from rodfem.errors import NewtonFailure, ParameterError
from rodfem.fem.sampled import ReducedState, SampledForm
from rodfem.nls.newton import Solve

DEFAULT_TOL = 1e-3        # relative fit residual of the training contributions (benchmarks/nonlinear_reduce.md)
DEFAULT_SNAPSHOTS = 40    # training states (evenly spread over the training run)
VANISHING = 1e-8          # an equation whose cells' contributions are below this (relative) vanishes identically


def check_parameters(tol, snapshots):
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and 0 < tol < 1):
        raise ParameterError(f"--ecsw-tol must be a number in (0, 1) (the relative fit residual; got {tol!r})")
    if not (isinstance(snapshots, (int, np.integer)) and not isinstance(snapshots, bool) and snapshots >= 1):
        raise ParameterError(f"ecsw snapshots must be an integer >= 1 (training states; got {snapshots!r})")


@dataclass
class Sample:
    """The sampled cells, their weights (> 0), the fit's relative residual, the tolerance and the training size."""
    cells: np.ndarray
    weights: np.ndarray
    fit_residual: float
    tol: float
    elements: int
    rows: int
    training_s: float = 0.0

    def to_dict(self):
        return {"cells": self.cells.tolist(), "weights": self.weights.tolist(), "fit_residual": self.fit_residual,
                "tol": self.tol, "elements": self.elements, "sampled": int(len(self.cells)), "rows": self.rows,
                "training_s": self.training_s}


def _body(problem):
    (name, body), = problem.body_items()
    return name, body


def reduced_state(problem, basis: Basis):
    """A ReducedState of the problem's one body in the basis (its Dirichlet rows dropped)."""
    _, body = _body(problem)
    bc = np.concatenate([np.asarray(b.dof_indices()[0], dtype=np.int64) for b in body.bcs]) if body.bcs else []
    rq, re = basis.ranks["configuration"], basis.ranks["energy"]
    ends = np.cumsum([0, rq, rq, re, re])
    return ReducedState(basis.V, basis.x_ref, body.x1, body.x0, bc, list(zip(ends[:-1], ends[1:])))


def training_matrix(problem, basis: Basis, snapshots, count=DEFAULT_SNAPSHOTS):
    """G (rows x cells) of the module docstring, each row scaled, from the full states `snapshots` (columns; the
    first the initial state), `count` of them evenly spread."""
    layout(problem)
    name, _ = _body(problem)
    X = np.asarray(snapshots, dtype=float)
    state = reduced_state(problem, basis)
    F = SampledForm(problem.compiled[(name, "F")], state)
    H = SampledForm(problem.compiled[(name, "H")], state)
    state.freeze()
    picks = np.unique(np.linspace(1, X.shape[1] - 1, min(count, X.shape[1] - 1)).round().astype(int))
    blocks = {"rate": [], "force": [], "energy": []}
    for k in picks:
        xi1, xi0 = basis.coordinates(X[:, k]), basis.coordinates(X[:, k - 1])
        state.set(xi1, xi0)
        blocks["rate"].append(F.evaluate(separate=True)[0].T)     # (reduced equations, cells)
        state.set(xi1, xi1)
        blocks["force"].append(F.evaluate(separate=True)[0].T)
        blocks["energy"].append(H.evaluate(separate=True)[0][None, :])
    rows = []
    for key, parts in blocks.items():
        G = np.stack(parts)                       # (snapshots, equations, cells)
        scale = np.sqrt(np.sum(G ** 2, axis=(0, 2)))
        keep = scale > VANISHING * scale.max(initial=0.0)
        rows.append((G[:, keep] / scale[None, keep, None]).reshape(-1, G.shape[2]))
    return np.vstack(rows), F.cells


def nnls(G, tol, target=None, max_size=None):
    """w >= 0 with |G w - b| <= tol |b| and few w > 0, b = `target` (default G 1) (Lawson-Hanson's active set, stopped at the
    tolerance; normal equations on the active set, the stopping test by the Gram form of the residual, good to
    about 1e-7 of |G 1|: tolerances below that run to the end).  Returns (w, relative residual)."""
    n = G.shape[1]
    gram = G.T @ G
    goal = G @ np.ones(n) if target is None else np.asarray(target, dtype=float)
    b = G.T @ goal
    bb = float(goal @ goal)
    limit = tol * np.sqrt(bb)
    w, active, banned = np.zeros(n), np.zeros(n, bool), np.zeros(n, bool)

    def residual(w):
        return np.sqrt(max(float(w @ gram @ w - 2.0 * w @ b + bb), 0.0))
    max_size = n if max_size is None else max_size
    while residual(w) > limit and active.sum() < max_size:
        g = b - gram @ w                     # -gradient of |G w - G 1|^2 / 2
        g[active | banned] = -np.inf
        j = int(np.argmax(g))
        if not g[j] > 0:
            break
        active[j] = True
        for _ in range(n):
            idx = np.flatnonzero(active)
            try:
                z = np.linalg.solve(gram[np.ix_(idx, idx)], b[idx])
            except np.linalg.LinAlgError:
                z = np.linalg.lstsq(gram[np.ix_(idx, idx)], b[idx], rcond=None)[0]
            if np.all(z > 0):
                w[:] = 0.0
                w[idx] = z
                break
            neg = z <= 0
            wi = w[idx]
            alpha = float(np.min(wi[neg] / (wi[neg] - z[neg])))
            w[idx] = wi + alpha * (z - wi)
            drop = idx[(w[idx] <= 0.0) | (neg & (wi == 0.0) & (alpha == 0.0))]
            w[drop] = 0.0
            active[drop] = False
            if j in drop:                    # the new cell cannot enter with a positive weight
                banned[j] = True
                break
    # (the residual reported from G itself: the Gram form loses digits near 0)
    return w, float(np.linalg.norm(G @ w - goal) / max(np.linalg.norm(goal), 1e-300))


def train(problem, basis: Basis, snapshots, tol=DEFAULT_TOL, count=DEFAULT_SNAPSHOTS) -> Sample:
    """The ECSW sample of `problem` (a built single-body System) for the basis, from the training run's full
    states `snapshots` (one per column): see the module docstring."""
    check_parameters(tol, count)
    t0 = time.perf_counter()
    G, cells = training_matrix(problem, basis, snapshots, count)
    w, res = nnls(G, tol)
    keep = w > 0
    return Sample(cells[keep].astype(np.int64), w[keep], float(res), float(tol), len(cells), int(G.shape[0]),
                  time.perf_counter() - t0)


KEEP = 0.1   # the kept Jacobian is evaluated anew when an iteration reduces the residual by less than this


class HyperReducedSystem(ReducedSystem):
    """The reduced model of galerkin.ReducedSystem with the ECSW sample: its residual, Jacobian, H_w, supplied work
    and facet outputs on the sampled cells and the facets only (module docstring).  `timings`: seconds spent forming
    the state on the sample's dofs ('state'), in the residual and Jacobian (kernels and projection together:
    'assemble_F', 'assemble_J'), solving ('solve') and in H_w, the work and the outputs ('outputs')."""

    reuse_jacobian = True

    def __init__(self, problem, basis: Basis, sample: Sample, start=None):
        if np.any(~(sample.weights > 0)) or len(sample.weights) != len(sample.cells):
            raise ParameterError("hyper-reduction: the weights must be > 0, one per sampled cell")
        super().__init__(problem, basis, start)
        name, _ = _body(problem)
        c = problem.compiled
        self.sample = sample
        self.rstate = st = reduced_state(problem, basis)
        cells, w = sample.cells, sample.weights
        self.F = SampledForm(c[(name, "F")], st, cells, w)
        self.J = SampledForm(c[(name, "J")], st, cells, w)
        self.H = SampledForm(c[(name, "H")], st, cells, w)
        self.W = SampledForm(c[(name, "work")], st, cells, w) if c.get((name, "work")) is not None else None
        self.D = SampledForm(c[(name, "dissipation")], st, cells, w) if c.get((name, "dissipation")) is not None else None
        from dolfinx.fem import IntegralType
        self.columns = {k[4:]: c[(n, k)] for (n, k) in c if n == name and k.startswith("obs:")}
        self.facet_outputs = all(set(f.integral_types) <= {IntegralType.exterior_facet} for f in self.columns.values())
        self.outputs = {k: SampledForm(f, st) for k, f in self.columns.items()} if self.facet_outputs else {}
        st.freeze()
        st.set(self.xi1, self.xi0)
        x0 = basis.full(self.xi0)
        self.F.check(x0, x0)
        problem.restore((x0, []))
        self.timings = {"state": 0.0, "assemble_F": 0.0, "assemble_J": 0.0, "solve": 0.0, "outputs": 0.0}
        self._lu, self.jacobians = None, 0

    def _push_x0(self):
        if not hasattr(self, "rstate"):
            return super()._push_x0()
        self.rstate.set(self.xi1, self.xi0)

    def _set_x1(self, xi):
        t0 = time.perf_counter()
        self.rstate.set(xi)
        self.timings["state"] += time.perf_counter() - t0

    def _residual(self, xi):
        self._set_x1(xi)
        t0 = time.perf_counter()
        r = self.F.evaluate()
        self.timings["assemble_F"] += time.perf_counter() - t0
        return r

    def _jacobian(self):
        t0 = time.perf_counter()
        Jr = self.J.evaluate()
        self.timings["assemble_J"] += time.perf_counter() - t0
        return Jr

    def set_step(self, h):
        if float(h) != self.dt:
            self._lu = None   # (the Jacobian holds 1/h)
        super().set_step(h)

    def solve(self, step, t):
        """xi_{n+1}: Newton on V^T F_w(xi) = 0 with the tolerances of galerkin.ReducedSystem.solve.  With
        `reuse_jacobian` (default) the factorized reduced Jacobian is kept from iteration to iteration and step to
        step while the residual falls by at least KEEP per iteration, and evaluated anew otherwise (the solution
        is the same: the convergence test is on the residual).  The converged iterate gets the correction of its
        residual too: a kept Jacobian converges linearly, and would stop just below the absolute tolerance, the
        energy balance then exact only to that tolerance (1e-12 of H instead of 1e-14)."""
        self.rstate.set(self.xi1, self.xi0)
        xi = self.xi1.copy()
        r0 = dxi = previous = None
        for it in range(MAX_IT + 1):
            r = self._residual(xi)
            norm = float(np.linalg.norm(r))
            if not np.isfinite(norm):
                raise NewtonFailure(step, t, norm, it, "non-finite reduced residual")
            r0 = norm if r0 is None else r0
            small = dxi is not None and np.linalg.norm(dxi) <= STOL * np.linalg.norm(xi)
            if norm <= ATOL or norm <= RTOL * r0 or small:
                if self._lu is not None:   # the last correction too (a solve; no evaluation)
                    xi = xi + scipy.linalg.lu_solve(self._lu, -r, check_finite=False)
                self.xi1 = xi
                self.iterations += it
                return Solve(it, norm)
            if it == MAX_IT:
                break
            if self._lu is None or not self.reuse_jacobian or (previous is not None and norm > KEEP * previous):
                Jr = self._jacobian()
                self._lu = scipy.linalg.lu_factor(Jr, check_finite=False)
                self.jacobians += 1
            t0 = time.perf_counter()
            dxi = scipy.linalg.lu_solve(self._lu, -r, check_finite=False)
            self.timings["solve"] += time.perf_counter() - t0
            if not np.all(np.isfinite(dxi)):
                raise NewtonFailure(step, t, norm, it, "singular reduced Jacobian")
            previous = norm
            xi = xi + dxi
        self._lu = None
        raise NewtonFailure(step, t, norm, MAX_IT, "reduced Newton: no convergence")

    def hamiltonian(self):
        """H_w(xi_{n+1}) = sum_e w_e H_e (+ the facet terms)."""
        t0 = time.perf_counter()
        self.rstate.set(self.xi1)
        H = self.H.evaluate()
        self.timings["outputs"] += time.perf_counter() - t0
        return H

    def supplied_work(self):
        """h y.u of the step (xi_n -> xi_{n+1}), weighted as the residual (the facet ports exact)."""
        if self.W is None:
            return 0.0
        t0 = time.perf_counter()
        self.rstate.set(self.xi1, self.xi0)
        work = self.W.evaluate()
        self.timings["outputs"] += time.perf_counter() - t0
        return work

    def dissipated_energy(self):
        """h d_n of the step, weighted as the residual (Kelvin-Voigt / Rayleigh damping)."""
        if self.D is None:
            return 0.0
        t0 = time.perf_counter()
        self.rstate.set(self.xi1, self.xi0)
        d = self.D.evaluate()
        self.timings["outputs"] += time.perf_counter() - t0
        return d

    def observe(self):
        t0 = time.perf_counter()
        if self.facet_outputs:
            self.rstate.set(self.xi1)
            out = {k: f.evaluate() for k, f in self.outputs.items()}
        else:   # a cell-integral output: at full order from x_ref + V xi
            ReducedSystem._set_x1(self, self.xi1)
            out = self.problem.observe()
        self.timings["outputs"] += time.perf_counter() - t0
        return out
