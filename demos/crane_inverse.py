# # Crane inverse dynamics: the inputs that carry the payload along a prescribed path
#
# `crane-manoeuvre` and `crane-payload` push the trolley with a given force
# F(t) and watch the payload swing.  This scene asks the inverse question of
# Blajer & Kolodziejczyk ("A geometric approach to solving problems of control
# constraints: theory and a DAE framework", Multibody Syst Dyn 11 (2004)
# 343-364): which inputs move the payload along a PRESCRIBED path -- here a
# rest-to-rest transfer by `distance` along the rail while lifting it by
# `lift`, in t_move seconds -- and then checks the answer by feeding the
# computed inputs back open loop.
#
# ## The crane: a trolley on a rail and a winch
#
# A trolley of mass M (point mass at the origin, z up, gravity in -z) rides
# on a horizontal rail: a `slider` joint to the ground holds its y and z.  A
# payload of mass m hangs L below it on a rope of variable length, wound by a
# winch.  Two inputs for the two prescribed coordinates (x_P, z_P) of the
# payload: the trolley force F along the rail (rodfem.core.servo.along) and
# the rope's tension T (rodfem.core.servo.winch: the force -T e on the
# payload, +T e on the trolley, e = (x_P - x_T)/|x_P - x_T|).
#
# ## The servo constraint
#
# `System.servo(payload, path, [F, T])` adds the rows G_s v_m = (path(t_{n+1})
# - path(t_n))/h for g_s = (x_P, z_P) - path(t), and the unknown inputs u =
# (F, T) enter the momentum rows as B(q_m) u: the column is B (e_x on the
# trolley; the rope's direction on both points), not G_s^T (rodfem/core/servo.py).
# The payload is reached by F only through the rope's direction: the DAE has
# index 5 (Altmann & Heiland, Multibody Syst Dyn 40 (2017) 75-98,
# doi:10.1007/s11044-016-9558-z).  The payload sits on the path at every
# step (to Newton's tolerance); the inputs' work is booked in `supplied`, so
# H_{n+1} - H_n = h y.u still closes every step.
#
# ## The answer it must give: the crane is flat
#
# The payload's path alone fixes everything.  The rope pulls the payload with
# m (x_P'' + g e_z), so the rope runs along a = x_P'' + g e_z, its tension is
# T = m |a|, the trolley sits where the rope meets the rail,
#
#     x_T = x_P - z_P a_x / a_z        (the rail at height 0),
#
# and the trolley's balance gives F = M x_T'' + m x_P''_x (x_T'' needs the
# path's 4th derivative: index 5).  The history records these as `F_flat`,
# `T_flat`, `trolley_x_flat`.
#
# ## What the midpoint rule does with an index-5 servo
#
# The positions and the tension T (an input that acts on the payload itself)
# converge to the flat solution at O(h^2): at h = 0.05, 0.025, 0.0125 the
# trolley's position is off by 6.4e-3, 1.6e-3, 3.9e-4 m, T by 4.9e-3, 1.2e-3,
# 3.0e-4 N.  The trolley force does not, by itself: the implicit midpoint rule
# maps s to (2/h)(z - 1)/(z + 1), so the force -> path transfer function
# (relative degree 4) gets a triple zero at z = -1, and the exact discrete
# inverse carries parasitic inputs (-1)^n p(n) that move no position.  They
# are excited where the path is not flat enough at rest: the path here is a
# smoothstep whose derivatives 1..`flat` vanish at both ends; with flat = 4
# (the 5th derivative jumps) the raw force is off by 850 to 3500 N on a 3 N
# force.  And they grow in time, the faster the smaller h: with flat = 8 the
# raw force is off by 1.5 N (of 8.5 N) at h = 0.05 and 0.025, by 117 N at
# h = 0.0125.  The zero-phase filter (u_{n-1} + 2 u_n + u_{n+1})/4
# (rodfem.core.servo.smoothed) removes (-1)^n (a + b n): the filtered force is
# off by 0.34, 0.090, 0.038 N at h = 0.1, 0.05, 0.025 (orders 1.9, 1.2), then
# by 1.4 N at h = 0.0125 -- below h = 0.025 the direct servo's force stops
# converging, while the path it realizes still does (benchmarks/bench_servo.py).
#
# ## The open-loop check
#
# The inputs are fed back to the ordinary crane -- the trolley force as a
# load, the tension as a control law along the rope -- with the same steps,
# held over each step (a load is read at the step's midpoint): `replay=raw`
# is the same set of discrete equations and puts the payload back on the path
# to Newton's tolerance (`path_error` 7e-11 m); `replay=filtered` (the
# default, the physical input) to O(h^2): 2.7e-2, 6.8e-3, 1.7e-3 m at
# h = 0.05, 0.025, 0.0125.
#
# ## Why not the flexible cable of crane-manoeuvre
#
# The same servo on the string of `crane-manoeuvre` (the trolley pushed along
# its rail by F, the payload's horizontal path prescribed: `cable_servo`
# below) has no bounded solution.  The finite-element cable's consistent
# mass couples its two ends at once, so the servo holds the payload by
# accelerating the top against the tension: the zero dynamics (the cable
# with its end held on the path) are unstable, with the rates 7.7, 17.2,
# 26.6, 36.0 /s for n = 1, 2, 3, 4 elements (the linearized cable's
# generalized eigenvalues; |F| grows at the fitted 8.0, 17.4, 27.8, 39.3 /s).
# Over 3 s: |F| = 1.5e9 N for one element (1.6e9, 1.5e9, 1.5e9 for h = 0.05,
# 0.025, 0.0125: the semi-discrete model, not the time step), 1.2e20 N for
# two, 3.5e44 N for four (where the path is no longer held).  A stiff cable
# (EA = 2000) fails sooner (Newton, at t = 0.5 s), and prescribing the
# payload's height too with a hoisting top (two inputs) grows the same way.
# The continuous cable is flat (Petit & Rouchon, "Flatness of heavy chain
# systems", SIAM J Control Optim 40 (2001) 475-495), but its trolley motion
# depends on the payload's path over [t - tau, t + tau], tau the wave's
# travel time: no forward time stepping of a servo constraint can find it.
# And the rigid rope of fixed length with the trolley force alone
# (crane-manoeuvre's one input) is singular: the payload's x has relative
# degree 4 while the rope hangs vertically and 2 once it swings out (the
# tension's horizontal part is T sin(theta)); Newton fails at t = 1.8 to
# 2.4 s.  Hence the winch.
#
# What to look at: `payload_x, _z` against `path_x, _z` and `path_error`
# (the open-loop check), `F` and `T` (the inputs applied) against `F_flat`,
# `T_flat`, `F_servo` (the servo's raw force: the parasitic mode, small for
# the default flat path and step), `trolley_x` against `trolley_x_flat`, the
# rope's length `rope`.
#
# Run it:  rodfem run crane-inverse --out results/crane-inverse
#          rodfem run crane-inverse --set replay=raw --set dt=0.0125
#          rodfem run crane-inverse --set flat=4        (the parasitic mode in F_servo)

import sys
from types import SimpleNamespace

import numpy as np

from rodfem import GROUND, Load, Support, System, run
from rodfem.app.cli import main
from rodfem.app.scene import Parameter, Scene, common, stiffness
from rodfem.core.servo import Transfer, along, step_inputs, winch
from rodfem.demos._multibody import nodal
from rodfem.demos._string_statics import static_equilibrium
from rodfem.demos.hanging_cable import hanging_guess, string_model
from rodfem.errors import ParameterError
from rodfem.forms import joints
from rodfem.forms.components import control_law, squared_length
from rodfem.forms.rigid_body import PointMass

parameters = [p for p in common(n_elements=1, dt=0.025, t_end=3.0, integrator="discrete-gradient")
              if p.name not in ("n_elements", "section")] + [
    stiffness("L", 1.0, "m", "rope length at rest: the payload hangs L below the trolley"),
    stiffness("g", 9.81, "m/s^2", "gravity, acting in -z (it keeps the rope taut)"),
    stiffness("mass", 0.5, "kg", "mass of the payload"),
    stiffness("trolley_mass", 1.0, "kg", "mass of the trolley"),
    Parameter("distance", 1.0, "m", "the payload's transfer along the rail (x)"),
    Parameter("lift", 0.3, "m", "the payload's lift during the transfer (z; less than L)"),
    Parameter("t_move", 2.0, "s", "duration of the transfer, from t = 0 (at rest before and after)",
              low=0, low_open=True),
    Parameter("flat", 8, "", "the path's smoothstep has vanishing derivatives 1..flat at both ends",
              low=1, high=20),
    Parameter("replay", "filtered", "", "the inputs fed back open loop: through the zero-phase filter, or "
              "the servo's own", choices=("filtered", "raw")),
]
# Two point masses and a rope: no flexible body, so no n_elements.


def transfer(p):
    """The payload's path (3D, z up): from L below the trolley to `distance` along x, `lift` higher."""
    L = p["L"]
    return Transfer((0.0, 0.0, -L), (p["distance"], 0.0, -L + p["lift"]), 0.0, p["t_move"], p["flat"])


def flat(p, t):
    """The flat solution at time t (see the prose): trolley_x, F and T."""
    path, g, M, m = transfer(p), p["g"], p["trolley_mass"], p["mass"]
    (x, _, z), (_, _, vz), (ax, _, az), (jx, _, jz), (sx, _, sz) = (path(t, k) for k in range(5))
    # x_T = x - N/D, N = z a_x, D = a_z + g; (N/D)'' by the quotient rule
    N, N1, N2 = z * ax, vz * ax + z * jx, az * ax + 2 * vz * jx + z * sx
    D, D1, D2 = az + g, jz, sz
    q2 = (N2 * D**2 - 2 * N1 * D1 * D - N * D2 * D + 2 * N * D1**2) / D**3
    return {"trolley_x": x - N / D, "F": M * (ax - q2) + m * ax, "T": m * np.hypot(ax, az + g)}


def crane(p, comm, inputs=None):
    """The rail crane: with `inputs` None the servo problem (F and T unknown), else the ordinary crane
    driven by inputs(t) = (F, T) (a load on the trolley, a control law along the rope)."""
    system = System(integrator=p["integrator"], comm=comm)
    M, m, g, L = p["trolley_mass"], p["mass"], p["g"], p["L"]
    # ## The trolley on its rail, the payload L below it, both under gravity
    loads = [Load("v", [0.0, 0.0, -M * g], "domain", "trolley weight")]
    if inputs is not None:
        loads.append(Load("v", lambda t: np.array([inputs(t)[0], 0.0, 0.0]), "domain", "trolley force"))
    trolley = system.add("trolley", PointMass(M), initial=PointMass.initial((0.0, 0.0, 0.0)), loads=loads)
    payload = system.add("payload", PointMass(m), initial=PointMass.initial((0.0, 0.0, -L)),
                         loads=[Load("v", [0.0, 0.0, -m * g], "domain", "payload weight")])
    system.join(joints.slider((1.0, 0.0, 0.0)), GROUND, trolley.point(), name="rail")
    if inputs is None:
        # ## The servo constraint: (x_P, z_P) on the path, by the trolley force and the winch
        path = transfer(p)
        system.servo(payload.point(), lambda t: path(t)[[0, 2]],
                     [along((1.0, 0.0, 0.0)).at(trolley.point()), winch().between(trolley.point(), payload.point())],
                     axes=(0, 2), name="servo")
    else:
        # ## The winch as a control law along the squared rope length c: force -T e on the payload
        system.connect(control_law(lambda t, c, rate: -inputs(t)[1] / (2.0 * np.sqrt(c)), measure=squared_length),
                       trolley.point(), payload.point(), name="winch")
    system.marker("trolley", trolley.point())
    system.marker("payload", payload.point())
    return system


def columns(p, applied, servo):
    """History columns of the open-loop run: the path and the distance from it, the inputs applied (those
    of the step that ends at the row's time) and the servo's raw force, the flat solution."""
    path = transfer(p)

    def record(system):
        t1, h = system.points.times[1], system.dt
        tm = max(t1 - 0.5 * h, 0.0)            # the step's midpoint, where its inputs are read
        target = path(t1)
        x_P = nodal(system.body("payload"), "x")[1][0]
        x_T = nodal(system.body("trolley"), "x")[1][0]
        F, T = applied(tm)
        exact, at_rest = flat(p, tm), flat(p, t1)
        return {"path_x": target[0], "path_z": target[2],
                "path_error": float(np.linalg.norm((x_P - target)[[0, 2]])), "rope": float(np.linalg.norm(x_P - x_T)),
                "F": F, "T": T, "F_servo": servo(tm)[0], "F_flat": exact["F"], "T_flat": exact["T"],
                "trolley_x_flat": at_rest["trolley_x"]}
    return record


def build(p, comm):
    if not 0.0 <= p["lift"] < p["L"]:
        raise ParameterError(f"parameter 'lift' must be in [0, L) = [0, {p['L']:g}) (got {p['lift']:g}): "
                             "the payload stays below the rail")
    # ## The inverse problem: run the servo crane over the whole time
    inverse = run(crane(p, comm), p["dt"], p["t_end"])
    servo = step_inputs(inverse.rows, "servo")
    applied = step_inputs(inverse.rows, "servo", smooth=p["replay"] == "filtered")
    # ## The open-loop check: the ordinary crane driven by the computed inputs (what this scene runs)
    replay = crane(p, comm, inputs=applied)
    replay.record(columns(p, applied, servo))
    return replay


def cable_servo(n_elements, dt, EA=20.0, comm=None, integrator="discrete-gradient"):
    """The ill-posed flexible case (see the prose): crane-manoeuvre's cable (rhoA = 1, L = 1, the payload
    0.5 kg lumped at its end, the trolley's top node on its rail) hanging in its static equilibrium, the
    payload's x prescribed (the default transfer) by the trolley force along the rail."""
    from mpi4py import MPI
    p = {"material": "logarithmic", "EA": EA, "rhoA": 1.0, "g": 9.81, "L": 1.0}
    m = 0.5
    system = System(integrator=integrator, comm=comm or MPI.COMM_WORLD,
                    newton_options={"snes_atol": 1e-11, "snes_rtol": 1e-14, "snes_max_it": 50})
    loads = [Load("v", [0.0, 0.0, -p["rhoA"] * p["g"]], "domain", "gravity"),
             Load("v", [0.0, 0.0, -m * p["g"]], "right", "load weight")]
    cable = system.add("cable", string_model(p, end_masses={"right": m}), p["L"], n_elements, loads=loads,
                       supports=[Support("left", "fix-z")], initial={"r": hanging_guess(p, m)})
    static_equilibrium(SimpleNamespace(**vars(cable.body)), supports=[Support("left", "pinned")])
    path = Transfer((0.0,), (1.0,), 0.0, 2.0, 8)
    system.servo(cable.end, path, [along((1.0, 0.0, 0.0)).at(cable.start)], axes=(0,), name="servo")
    system.marker("payload", cable.end)
    system.marker("trolley", cable.start)
    return system


scene = Scene("crane-inverse", "inverse dynamics of a rail crane with a winch: the trolley force and rope tension "
              "that carry the payload along a prescribed path (servo constraint), fed back open loop",
              parameters, build,
              notes="The run is the open-loop check; the servo problem is solved when the scene is built.  "
                    "H excludes the gravity potential: gravity is an input, its work is in 'supplied'.")

if __name__ == "__main__":
    sys.exit(main(["run", scene.name, *sys.argv[1:]]))
