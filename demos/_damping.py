# Material damping parameters shared by the scenes of the planar beam, the 3D
# rod and the string (forms/damping.py): Kelvin-Voigt dashpots in parallel
# with the elastic law, viscosities eta_i = tau_kv k_i (k_i the section's
# small-strain stiffnesses EA, GA, EI, GJ, ...; tau_kv = eta/E the
# retardation time of a Kelvin-Voigt solid sigma = E eps + eta d_t eps),
# and Rayleigh's mass-proportional part alpha (a force -alpha rho v on every
# mass).  Rayleigh's stiffness-proportional beta IS tau_kv.  All zero (the
# default): nothing is built.
from rodfem.app.scene import Parameter


def damping_parameters():
    return [
        Parameter("tau_kv", 0.0, "s", "Kelvin-Voigt retardation time eta/E: viscous stresses tau_kv x (EA, GA, EI, ...) "
                  "x strain rates (= Rayleigh's beta; modal damping ratio tau_kv omega/2; 0: none)", low=0),
        Parameter("rayleigh_alpha", 0.0, "1/s", "Rayleigh mass-proportional damping: force -alpha rho v on every mass "
                  "(modal damping ratio alpha/(2 omega); damps rigid motions too; 0: none)", low=0),
    ]


def damping(p, rayleigh, *stiffnesses):
    """The model's damping rayleigh(alpha, tau_kv, *stiffnesses) (its module's `rayleigh`), None if both are 0."""
    if p["tau_kv"] == 0 and p["rayleigh_alpha"] == 0:
        return None
    return rayleigh(p["rayleigh_alpha"], p["tau_kv"], *stiffnesses)
