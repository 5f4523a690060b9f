"""What rodfem asks of a model (the physics lives in forms/, never here).

A model is any object with

``fields``       list of `Field`: the state x = (x_1, ..., x_n)
``supports``     dict kind -> field names fixed by that support, e.g.
                 {"clamped": ["r", "phi", "v", "omega"], "pinned": ["r", "v"]};
                 "r.1" fixes only component 1 of r
``position``     name of the centreline field (for tips and pictures)
``quadrature_degree``   int, used for every cell integral of the model
``hamiltonian(x, dx, ds)``   the Hamiltonian H(x) as a UFL form (ds(1), ds(2): the
                 ends s = 0, L, for lumped energies such as end masses)
``residual(step, test, dx, ds)``
                 the weak form of E (x_{n+1} - x_n)/h - J(x_{n+1/2}) z = 0
                 (no loads: the port layer adds B u), built from
                 `step.rate`, `step.mid` and `step.effort`
``compatible_strains(x)``
                 dict strain-field -> UFL expression of the configuration,
                 used to start the strains consistent with the initial shape
``momentum(x)``  dict column -> density of momentum maps (p_x, ..., L_z),
                 written for unsupported bodies; may be empty

Optional, for a model with dissipation (E x' = (J - R) z + B u, R >= 0):

``dissipation(step, dx, ds)``
                 the energy h d_n >= 0 the step dissipates, as a UFL form (h = step.h),
                 such that H(x_{n+1}) - H(x_n) = -h d_n + h y.u holds exactly for the
                 step's residual (e.g. h int z.R z ds with z the residual's efforts of
                 the dissipative rows); None (or no such method) when the model
                 dissipates nothing: then nothing is built or assembled for it
                 (forms/viscoelastic.py: generalized Maxwell branches)

Optional, for the nonlinear reduced model (rodfem/analysis/galerkin.py):

``efforts``      dict energy-variable field -> its effort field (an algebraic field of the same
                 element: the projection of the step's effort, read by the rows in its place),
                 e.g. {"Gamma": "N", "kappa": "M"}

Optional, for what a run writes (rodfem/io/snapshot.py, rodfem/io/frames.py):

``outputs(x)``   dict name -> UFL expression of the state x: the strains and stress resultants
                 written beside the state (cell by cell, at the nodes and segment midpoints)
``directors(q)`` numbers: q dict field -> nodal values (n, size); returns the section frame
                 (n, 3, 3), columns d1 (axis), d2, d3 (the section); a planar model's plane is
                 z = 0, d3 = e_z.  Without it a body has no section (a string: a round tube)
``columns(x, dx, ds, length)``
                 dict column -> UFL functional of the state x = x_{n+1}: the model's own history
                 columns (e.g. a thermal model's entropy and mean temperature; length = L)
``labels``       dict field or output name -> (description, component names)
``units``        dict field or output name -> its SI unit ("1": dimensionless), written in the
                 files' field data and fields.json
``massless``     True when the model has no inertia: its velocities (the values of
                 ``kinematics``) are not written
``box()``        a rigid body's edge lengths (a1, a2, a3) along (d1, d2, d3), for pictures
``section``      set by a scene (rodfem.io.sections.Section): the cross-section drawn (a rod's, or
                 a rigid body's link's)
``link``         set by a scene: a rigid body drawn as a link through these points (k, 3) of its
                 frame (e.g. its joint points) instead of its box

`Model` and `SteppedSystem` below state these contracts as `typing.Protocol`s (checked by
type checkers, not at run time).
"""
from typing import Protocol, runtime_checkable

from rodfem.core.spaces import Field  # noqa: F401


@runtime_checkable
class Model(Protocol):
    """What the engine asks of a model (see the module docstring)."""

    fields: list
    supports: dict
    position: str
    quadrature_degree: int

    def hamiltonian(self, x, dx, ds):
        """H(x) as a UFL form."""

    def residual(self, step, test, dx, ds):
        """The weak form of E (x_{n+1} - x_n)/h - J(x_{n+1/2}) z (no loads)."""

    def compatible_strains(self, x) -> dict:
        """Strain field -> UFL expression of the configuration."""

    def momentum(self, x) -> dict:
        """History column -> density of a momentum map."""


@runtime_checkable
class SteppedSystem(Protocol):
    """What the time loop (rodfem/analysis/timeloop.py) asks of a system (rodfem.System)."""

    t: float
    comm: object

    def set_step(self, h: float) -> None:
        """The step h of the following steps."""

    def set_time(self, t: float) -> None:
        """The inputs u(t) of the next step (t = t_{n+1/2})."""

    def predict(self, previous) -> None:
        """Newton's start from x_n (and x_{n-1}, if not None)."""

    def solve(self, step: int, t: float):
        """x_{n+1} at time t (raises NewtonFailure)."""

    def accept(self):
        """x_n <- x_{n+1}; returns the old x_n."""

    def hamiltonian(self) -> float:
        """H(x_{n+1})."""

    def supplied_work(self) -> float:
        """h y.u of the last step."""

    def dissipated_energy(self) -> float:
        """h d_n >= 0 of the last step."""

    def observe(self) -> dict:
        """The history's columns of x_{n+1}."""
