"""One body alone: a `System` with one body, built at once.

    problem = Problem(model, length, n_elements, loads=[...], supports=[...], initial={...})
    run(problem, dt, t_end)

is `System` + `add` + `build` in one line, the form the single-body scenes use.  The body's own
attributes (its state Functions x0 and x1, space, mesh, model, loads, ...) read through the
problem (`problem.x0`, `problem.space`); F, J and H are its compiled forms.
"""
from typing import Optional, Sequence

from mpi4py import MPI

from rodfem.core.model import Model
from rodfem.core.ports import Load, Support
from rodfem.core.system import System


class Problem(System):
    """The discrete PH system of `model` on [0, L] with `n_elements` cells, ready to step.

    initial: dict field -> callable x -> values (x[0] = s) or UFL expression;
             strains not given are set from model.compatible_strains.
    `t` is the time of the state x_n (0 at the start; the time loop advances it).
    """

    def __init__(self, model: Model, length: float, n_elements: int, loads: Sequence[Load] = (),
                 supports: Sequence[Support] = (), initial: Optional[dict] = None, integrator: str = "midpoint",
                 comm=MPI.COMM_WORLD, newton_options: Optional[dict] = None, contacts: Sequence = ()):
        super().__init__(integrator, comm, newton_options)
        self._place("", model, length, n_elements, loads, supports, initial, contacts)
        self.build()

    def __getattr__(self, name):
        """The body's attributes (only for names the System does not have)."""
        bodies = self.__dict__.get("bodies")
        if name.startswith("__") or not bodies:
            raise AttributeError(name)
        return getattr(bodies[""].body, name)

    @property
    def F(self):
        """The compiled step residual."""
        return self.compiled[("", "F")]

    @property
    def J(self):
        """The compiled Jacobian dF/dx_{n+1}."""
        return self.compiled[("", "J")]

    @property
    def H(self):
        """The compiled Hamiltonian H(x_{n+1})."""
        return self.compiled[("", "H")]

    @property
    def work(self):
        """The compiled supplied work h y.u of a step (None without loads)."""
        return self.compiled[("", "work")]

    @property
    def D(self):
        """The compiled dissipated energy h d_n of a step (None for a conservative model)."""
        return self.compiled.get(("", "dissipation"))

    @property
    def observables_compiled(self):
        """History column -> its compiled functional."""
        return {k[4:]: self.compiled[("", k)] for k in self.columns}
