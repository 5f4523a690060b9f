# Parameters shared by the planar-beam demos: the material law and the
# element degree.  Each demo adds its own geometry and loads.
from rodfem.app.scene import Parameter
from rodfem.demos._damping import damping
from rodfem.forms import planar_beam

MATERIALS = {"hooke": planar_beam.quadratic, "log-axial": planar_beam.log_axial}


def material_parameters(material="hooke", degree=1):
    return [Parameter("material", material, "", "stored energy W(Gamma, kappa) (forms/planar_beam.py)",
                      choices=tuple(MATERIALS)),
            Parameter("degree", degree, "", "P_k kinematics with DG_(k-1) strains", low=1, high=3)]


def beam(p, kappa0=0.0):
    """The PlanarBeam of the parameters p (EA, GA, EI, rhoA, rhoI, material, degree; tau_kv and
    rayleigh_alpha if the scene has them: rodfem/demos/_damping.py)."""
    W = MATERIALS[p["material"]](p["EA"], p["GA"], p["EI"], kappa0)
    kv = damping(p, planar_beam.rayleigh, p["EA"], p["GA"], p["EI"]) if "tau_kv" in p else None
    return planar_beam.PlanarBeam(p["rhoA"], p["rhoI"], W, degree=p["degree"], damping=kv)
