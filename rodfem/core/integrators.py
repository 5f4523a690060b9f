"""Time integrators for E x' = J(x) z + B u, written as UFL residuals.

One step t_n -> t_{n+1} = t_n + h with x_{n+1/2} = (x_n + x_{n+1})/2:

    E (x_{n+1} - x_n)/h = J(x_{n+1/2}) z_{n,n+1} + B u_{n+1/2},   y = B^T z_{n,n+1}

The rules differ only in the co-energy (effort) z of the stored energy W:

* ``midpoint``:           z = dW/dx (x_{n+1/2})
  exactly energy-consistent when W is quadratic;
* ``discrete-gradient``:  z = Gonzalez' discrete gradient (pointwise)
      z = dW(x_m) + [W(x_{n+1}) - W(x_n) - dW(x_m).dx] dx / |dx|^2,  dx = x_{n+1} - x_n,
  so that z . dx = W(x_{n+1}) - W(x_n) exactly for ANY W.
  The bracket is O(|dx|^3) computed by cancellation: its round-off, about
  eps |W| / |dx| in z, would keep Newton's residual above its tolerance for
  small increments.  Where |dx| <= DG_THRESHOLD = 1e-3 (strains are
  dimensionless) the bracket is replaced by its Taylor expansion about x_m,
      W(x_{n+1}) - W(x_n) - dW(x_m).dx = D^3 W(x_m)[dx, dx, dx] / 24 + O(|dx|^5),
  whose energy error is <= |D^5 W| |dx|^5 / 1920 <= 5e-19 |D^5 W|, while above
  the threshold the quotient's round-off stays <= 2e-13 |W|.

With z tested in the space of the strain rows, H_{n+1} - H_n = h y.u follows
(see docs of each model in forms/).

`Step.scalar_effort` is the same rule for an energy W(a) of one scalar a(x) of the state that is
not a field (a contact's gap, a squared distance): midpoint W'(a(x_m)); discrete gradient the
difference quotient [W(a_{n+1}) - W(a_n)] / (a_{n+1} - a_n), with the Taylor term
W'(a_bar) + W^(3)(a_bar) da^2 / 24 where |da| <= a threshold the caller gives in the units of a.

``weights`` (optional, numbers >= 0 per component, default all 1) make the
correction act in a weighted metric, z = dW(x_m) + bracket (w dx)/(dx.w dx):
still z . dx = W(x_{n+1}) - W(x_n) if W does not depend on the components of
weight 0 (their effort is then dW/dx_i = 0 exactly, e.g. a constrained strain
whose stress is a multiplier).
"""
import ufl

RULES = ("midpoint", "discrete-gradient")
DG_THRESHOLD = 1e-3


def flatten(values):
    comps = []
    for v in values:
        if v.ufl_shape == ():
            comps.append(v)
        else:
            comps += [v[i] for i in range(v.ufl_shape[0])]
    return ufl.as_vector(comps)


def unflatten(vec, like):
    out, k = [], 0
    for v in like:
        if v.ufl_shape == ():
            out.append(vec[k])
            k += 1
        else:
            n = v.ufl_shape[0]
            out.append(ufl.as_vector([vec[k + i] for i in range(n)]))
            k += n
    return out


class Step:
    """UFL view of one time step: x_n, x_{n+1}, midpoint values, rates and efforts.

    `x0`, `x1` are dicts name -> UFL component (from StateSpace.split); `h` a
    Constant time step; `rule` one of RULES.
    """

    def __init__(self, x0, x1, h, rule):
        if rule not in RULES:
            raise ValueError(f"integrator must be one of {', '.join(RULES)} (got {rule!r})")
        self.x0, self.x1, self.h, self.rule = x0, x1, h, rule

    def mid(self, name):
        """x_{n+1/2} = (x_n + x_{n+1})/2."""
        return 0.5 * (self.x0[name] + self.x1[name])

    def rate(self, name):
        """(x_{n+1} - x_n)/h."""
        return (self.x1[name] - self.x0[name]) / self.h

    def effort(self, energy, names, weights=None):
        """Co-energies z_i of the energy density `energy(*x_names)`, one per name (`weights`: the
        metric of the discrete gradient's correction, one number or UFL constant per component)."""
        like = [self.x0[n] for n in names]
        X0, X1 = flatten(like), flatten([self.x1[n] for n in names])
        Xm = ufl.variable(0.5 * (X0 + X1))
        grad = ufl.diff(energy(*unflatten(Xm, like)), Xm)
        if self.rule == "discrete-gradient":
            dX = X1 - X0
            wdX = dX if weights is None else ufl.as_vector([w * dX[i] for i, w in enumerate(weights)])
            dX2 = ufl.inner(dX, wdX)
            dW = energy(*unflatten(X1, like)) - energy(*unflatten(X0, like))
            d3W = ufl.inner(ufl.diff(ufl.inner(ufl.diff(ufl.inner(grad, dX), Xm), dX), Xm), dX)
            bracket = ufl.conditional(ufl.gt(dX2, DG_THRESHOLD ** 2), dW - ufl.inner(grad, dX), d3W / 24.0)
            grad = grad + bracket / ufl.conditional(ufl.gt(dX2, 0.0), dX2, 1.0) * wdX
        return unflatten(grad, like)

    def scalar_effort(self, energy, a0, a1, am, threshold):
        """The co-energy of energy(a) for a scalar a of the state (UFL; a0, a1, am = a(x_n),
        a(x_{n+1}), a(x_{n+1/2})): midpoint energy'(am); discrete gradient the difference quotient
        (energy(a1) - energy(a0)) / (a1 - a0), so that z (a1 - a0) = energy(a1) - energy(a0) exactly,
        replaced by its Taylor expansion energy'(a_bar) + energy^(3)(a_bar) da^2 / 24 about
        a_bar = (a0 + a1)/2 where |a1 - a0| <= threshold (the quotient's cancellation)."""
        if self.rule != "discrete-gradient":
            A = ufl.variable(am)
            return ufl.diff(energy(A), A)
        A = ufl.variable(0.5 * (a0 + a1))
        d1 = ufl.diff(energy(A), A)
        d3 = ufl.diff(ufl.diff(d1, A), A)
        da = a1 - a0
        large = ufl.gt(abs(da), threshold)
        quotient = (energy(a1) - energy(a0)) / ufl.conditional(large, da, 1.0)
        return ufl.conditional(large, quotient, d1 + d3 * da ** 2 / 24.0)
