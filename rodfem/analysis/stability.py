"""Stability of a static equilibrium, read off the eigenvalues of the linearized model.

About an equilibrium x* the linear model (rodfem/analysis/linearize.py, the pencil of modes)

    E_m dx' = A_m dx

has, for a conservative system, the eigenvalues s = +-i omega where x* is a strict minimum of the
potential energy (stable: Lagrange-Dirichlet) and a pair s = +-sigma, sigma > 0, for each direction
in which the energy falls (unstable: a perturbation grows as e^{sigma t}).  Damping moves the
eigenvalues to the left, and cannot make an unstable equilibrium of a conservative system stable
(Kelvin-Tait-Chetaev), so the test is the same with it: by Lyapunov's indirect method, x* is

    unstable     if an eigenvalue has Re s > 0,
    stable       (asymptotically, with damping; in the linear sense without) if none has.

Zero eigenvalues (a mechanism's free motion, a free body's drift) are reported as neutral: the
linear model does not decide those directions.  Verified eigenvalues only (rodfem/la/pencil.py:
each refined and checked by its backward errors), by QZ of the whole pencil: serial, and up to
`DENSE_FALLBACK_MAX` states.

Not decided here: what the load path does beyond the equilibrium (a limit point, a bifurcation
ahead); `rodfem modes` gives the oscillations themselves.
"""
from rodfem.errors import ParameterError
from rodfem.la.pencil import Pencil, growing_eigenvalues

MODES = ("auto", "on", "off")
AUTO_MAX = 600       # auto: checked up to this many dofs (QZ and verification: about 1 s here at 600)


def check_mode(stability):
    if stability not in MODES:
        raise ParameterError(f"--stability must be one of {', '.join(MODES)} (got {stability!r})")


def equilibrium_stability(lin):
    """{'stable', 'growth_rate_1_s', 'unstable_eigenvalues', 'neutral_zeros', ...} of the
    Linearization `lin` about an equilibrium: growth_rate is the largest Re s (1/s) of the
    verified growing eigenvalues (0 if none)."""
    s, zeros, tried, rejected = growing_eigenvalues(Pencil(lin.Am, lin.Em))
    return {"checked": True, "stable": not len(s), "growth_rate_1_s": float(max(s.real, default=0.0)),
            "unstable_eigenvalues": [[float(z.real), float(z.imag)] for z in s],
            "neutral_zeros": zeros, "candidates_tried": tried, "candidates_rejected": rejected,
            "n_states": int(lin.Em.shape[0])}


def not_checked(why):
    return {"checked": False, "why": why}


def stability_of(problem, statics, t, mode="auto"):
    """The stability dict of the equilibrium that `statics` (rodfem/analysis/statics.py) has just
    found for `problem` at time t; mode 'auto' checks up to AUTO_MAX states, 'on' up to the dense
    limit, 'off' never.  What the linearization refuses (contact, servos, several ranks) is
    'not checked', with its reason."""
    from rodfem.analysis.linearize import DENSE_FALLBACK_MAX, Linearization
    check_mode(mode)
    limit = {"auto": AUTO_MAX, "on": DENSE_FALLBACK_MAX, "off": -1}[mode]
    if mode == "off":
        return not_checked("--stability off")
    if problem.dofs > limit:
        return not_checked(f"{problem.dofs} dofs, more than the {limit} that --stability {mode} takes"
                           + ("; --stability on takes up to " + str(DENSE_FALLBACK_MAX) if mode == "auto" else ""))
    ref = statics.refs if problem.named_bodies else statics.refs[""]
    try:
        lin = Linearization(problem, reference=ref, t=t)
    except ParameterError as e:
        return not_checked(str(e))
    return equilibrium_stability(lin)


def verdict(stability):
    """One line for the terminal, or None when there is nothing to say."""
    if not stability.get("checked"):
        return f"stability not checked: {stability['why']}"
    if stability["stable"]:
        zeros = stability["neutral_zeros"]
        return "stable: no eigenvalue of the linearized model has a positive real part" + (
            f" ({zeros} zero eigenvalues: neutral directions)" if zeros else "")
    n = len(stability["unstable_eigenvalues"])
    return (f"UNSTABLE equilibrium: {n} eigenvalue{'s' if n > 1 else ''} of the linearized model with positive real "
            f"part, the largest growth rate {stability['growth_rate_1_s']:.4g} 1/s (a perturbation grows as "
            f"e^(rate t)); the dynamic run would leave it")
