"""Stored energies W(C) of hyperelastic strings: one function per material.

C = d_s r . d_s r (square of the stretch lambda = |d_s r|) is the strain-type
state of the string (Kinon et al., PAMM 2023); the stress quantity is S = 2 W'(C), the
contact force n = S d_s r and the tension N = |n| = S lambda = 2 W'(C) sqrt(C).

Every material here has the same small-strain stiffness: near C = 1,
S ~ (EA/2)(C - 1) ~ EA (lambda - 1), i.e. W''(1) = EA/4.

Adding a material is writing ONE function of C (a UFL scalar) and its
parameters, decorated with `@material` -- `biot` below is the example:

    @material
    def biot(C, EA):
        # docstring: the formula, W = EA/2 (sqrt(C) - 1)^2, N = EA (lambda - 1)
        return EA / 2 * (ufl.sqrt(C) - 1) ** 2

`biot(EA=10.0)` then is a `Material` (rodfem/core/materials.py) the string model
takes; every parameter must be a positive number (checked: one-line
ValueError), and the parameters enter the compiled forms as run-time
constants, so changing a value does not recompile.  Add the name to MATERIALS to make it selectable
in the scenes (``--set material=biot``) and covered by the per-material
tests.  Any W works with the discrete-gradient integrator: the energy
balance is exact whatever W is.  Keep W''(1) = EA/4 so that EA is the
small-strain stiffness, and state where W is defined (e.g. C > 0).
"""
import ufl

from rodfem.core import materials


class Material(materials.Material):
    """A string material W(C; params), with its response for numbers C."""

    def stress(self, C):
        """S = 2 W'(C) as a float, for a number C (UFL evaluates the derivative)."""
        from ufl.algorithms import expand_derivatives
        c = ufl.variable(ufl.as_ufl(float(C)))
        return float(expand_derivatives(2 * ufl.diff(self(c), c)))

    def energy(self, C):
        """W(C) as a float, for a number C."""
        return float(self(ufl.as_ufl(float(C))))

    def tension(self, stretch):
        """N = S lambda = 2 W'(lambda^2) lambda for a uniform stretch lambda."""
        return self.stress(stretch ** 2) * stretch


def material(function):
    """Decorator: W(C, **params) -> a factory params -> Material (all parameters positive)."""
    return materials.material(function, cls=Material)


# -- the materials ---------------------------------------------------------------

@material
def kirchhoff(C, EA):
    """Kirchhoff-Saint-Venant type:  W = EA/8 (C - 1)^2  (= 1/2 EA E^2, E = (C - 1)/2).

    S = EA/2 (C - 1),  N = EA/2 (lambda^3 - lambda).  Quadratic in the state
    C, so the midpoint rule is already energy-consistent for it.
    """
    return EA / 8 * (C - 1) ** 2


@material
def logarithmic(C, EA):
    """The authors' law (Kinon et al., IFAC 2024; PAMM 2023):  W = EA/4 (C - ln C - 1).

    S = EA/2 (1 - 1/C),  N = EA/2 (lambda - 1/lambda).  W -> infinity as
    C -> 0 (no collapse to zero length); defined for C > 0 only.
    """
    return EA / 4 * (C - ufl.ln(C) - 1)


@material
def biot(C, EA):
    """Linear in the stretch:  W = EA/2 (sqrt(C) - 1)^2,  N = EA (lambda - 1).

    S = EA (1 - 1/sqrt(C)).  Needs C > 0 (the tangent is infinite at C = 0).
    """
    return EA / 2 * (ufl.sqrt(C) - 1) ** 2


def _asinh(y):
    """asinh(y) = sign(y) ln(|y| + sqrt(y^2 + 1)), free of cancellation for either sign."""
    a = abs(y)
    return ufl.sign(y) * ufl.ln(a + ufl.sqrt(a * a + 1))


@material
def tension_only(C, EA, delta=1e-3):
    """Slack cable: the Kirchhoff law in tension, (almost) no stiffness in compression.

    With x = C - 1 and the smooth ramp rho(x) = (x + sqrt(x^2 + delta^2))/2 ~ max(x, 0),

        S = 2 W'(C) = EA/2 rho(C - 1),
        W = EA/4 Phi(C - 1),   Phi(x) = int_0^x rho = [x^2 + x sqrt(x^2 + delta^2) + delta^2 asinh(x/delta)]/4.

    For C - 1 >> delta this is kirchhoff (W -> EA/8 (C - 1)^2); in compression
    S ~ EA delta^2/(8 |C - 1|) > 0, so the tangent stays finite and smooth:
    no kinks for Newton, no NaN for any C (also C <= 0).  delta is the width
    of the transition in C (default 1e-3, i.e. a stretch of 0.05 %).
    """
    x = C - 1
    root = ufl.sqrt(x * x + delta * delta)
    return EA / 16 * (x * x + x * root + delta * delta * _asinh(x / delta))


MATERIALS = {"kirchhoff": kirchhoff, "logarithmic": logarithmic, "tension-only": tension_only, "biot": biot}
