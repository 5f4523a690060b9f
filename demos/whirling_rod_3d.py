# # Whirling rod (3D Cosserat rod, free)
#
# A free, initially straight and stress-free rod along x, centred at the
# origin, is set spinning with the rigid velocity field v = Omega x r,
# w_i = Omega x d_i, where Omega = Omega0 (cos a, 0, sin a) is tilted by the
# angle a from the rod's axis: NOT a principal axis of inertia.  The rod
# wobbles, stretches under the centrifugal load and bends, with no load at
# all: the energy H and all three components of the angular momentum
#
#     L = int rhoA r x v + sum_i m_i d_i x w_i ds
#
# stay constant to round-off (columns H, L_x, L_y, L_z of history.csv).
# By default the cross-section is thin (rhoJ1 = rhoJ2 + rhoJ3), so the axis
# director d1 carries no mass (the DAE case of a singular mass matrix).
#
# Run it:  rodfem run whirling-rod-3d --out results/whirling-rod-3d

import sys

import numpy as np

from rodfem import Problem
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common
from rodfem.demos._rod3d import NEWTON, material_parameters, rod, straight

parameters = common(n_elements=8, dt=0.01, t_end=5.0) + [
    Parameter("L", 1.0, "m", "length", low=0, low_open=True),
    Parameter("Omega0", 6.0, "rad/s", "initial spin rate"),
    Parameter("tilt", 30.0, "deg", "angle between the spin axis and the rod axis"),
] + material_parameters(EA=1e3, GA=1e3, GJ=2.0, EI=2.0, rhoA=1.0, rhoJ=(0.02, 0.01, 0.01))


def build(p, comm):
    a = np.radians(p["tilt"])
    omega = p["Omega0"] * np.array([np.cos(a), 0.0, np.sin(a)])
    initial = straight((-0.5 * p["L"], 0.0, 0.0), np.eye(3), omega=omega)
    return Problem(rod(p), p["L"], p["n_elements"], initial=initial, integrator=p["integrator"], comm=comm,
                   newton_options=NEWTON)


scene = Scene("whirling-rod-3d", "free rod spinning about a non-principal axis: H and L_x, L_y, L_z conserved",
              parameters, build)

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
