"""One body alone: its forms compiled and solved by Newton, step by step.

`Problem` is the single-body case of a mechanism (rodfem/core/system.py joins
several); it is what the single-body scenes build.
"""
from dolfinx import fem
from mpi4py import MPI

from rodfem.fem import compat
from rodfem.core.body import Body
from rodfem.fem.jit import locked
from rodfem.nls.newton import Newton


def compile_forms(forms):
    """Compile a dict of UFL forms (None stays None).

    Every form is built before any is compiled: UFL's signatures (the JIT
    cache keys) depend on global counters that a compilation advances, so
    compiling F before J is even built would give J a different key in a cold
    and a warm process (a second run would recompile).
    """
    for f in forms.values():
        if f is not None:
            f.signature()  # computed (and kept by UFL) before any compilation
    comm = compat.form_comm(next(f for f in forms.values() if f is not None))
    with locked(comm):  # rodfem/fem/jit.py
        return {k: compat.form(f) if f is not None else None for k, f in forms.items()}


class Problem(Body):
    """The discrete PH system of `model` on [0, L] with `n_elements` cells, ready to step.

    initial: dict field -> callable x -> values (x[0] = s) or UFL expression;
             strains not given are set from model.compatible_strains.
    `t` is the time of the state x_n (0 at the start; the time loop advances it).
    """

    def __init__(self, model, length, n_elements, loads=(), supports=(), initial=None,
                 integrator="midpoint", comm=MPI.COMM_WORLD, newton_options=None):
        super().__init__(model, length, n_elements, loads, supports, initial, integrator, comm)
        self.t = 0.0
        compiled = compile_forms(self.forms())
        self.F, self.J, self.H, self.work = (compiled[k] for k in ("F", "J", "H", "work"))
        self.D = compiled.get("dissipation")   # h d_n; None: the model dissipates nothing
        self.observables_compiled = {k[4:]: f for k, f in compiled.items() if k.startswith("obs:")}
        self.newton = Newton(self.F, self.J, self.x1, self.bcs, options=newton_options)

    # -- one time step (the time loop's view of a problem) -------------------
    def predict(self, previous):
        """Newton's start: x_{n+1}^0 = 2 x_n - x_{n-1} (x_n if `previous` is None)."""
        if previous is None:
            self.x1.x.array[:] = self.x0.x.array
        else:
            self.x1.x.array[:] = 2.0 * self.x0.x.array - previous

    def solve(self, step, t):
        """x_{n+1} by Newton (raises NewtonFailure)."""
        return self.newton.solve(step, t)

    def accept(self):
        """x_n <- x_{n+1}; returns the old x_n (for the next prediction)."""
        previous = self.x0.x.array.copy()
        self.x0.x.array[:] = self.x1.x.array
        return previous

    # -- evaluation ---------------------------------------------------------
    def assemble(self, compiled):
        return self.comm.allreduce(fem.assemble_scalar(compiled), op=MPI.SUM)

    def supplied_work(self):
        """h y.u of the last step, with u at t_{n+1/2} and y = flow_{n+1/2}."""
        return self.assemble(self.work) if self.work is not None else 0.0

    @property
    def dissipates(self):
        """True if the model dissipates (the history then has the column 'dissipated')."""
        return self.D is not None

    def dissipated_energy(self):
        """h d_n >= 0 of the last step (0 without dissipation)."""
        return self.assemble(self.D) if self.D is not None else 0.0

    def hamiltonian(self):
        """H(x_{n+1})."""
        return self.assemble(self.H)

    def observe(self):
        return {k: self.assemble(f) for k, f in self.observables_compiled.items()}

