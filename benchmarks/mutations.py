"""Mutation check: does the test suite notice when the physics (or the contract) is broken?

Each mutation below is a small, deliberate break of the source: a file, an exact piece of text and
its replacement, and the tests that must catch it.  For every mutation the tracked files of the
repository are copied to a scratch directory, the text is replaced there (it must occur exactly
once, otherwise the mutation is reported as stale), and just the listed tests run in the copy, with
the copy first on PYTHONPATH (so that `rodfem`, `forms`, `demos`, the entry-point scenes, the
`rodfem` console script and `mpirun` children all import the mutated code; a preflight checks
this).  A mutation is caught when at least one of its tests fails; the table says which did.

    .venv/bin/python benchmarks/mutations.py                  # all mutations, a few minutes
    .venv/bin/python benchmarks/mutations.py --only helix-ignores-constraint dg-no-taylor-term
    .venv/bin/python benchmarks/mutations.py --list
    # which tests of another commit catch each mutation (whole suite per mutation, ~1 hour):
    .venv/bin/python benchmarks/mutations.py --ref main --all-tests --out /tmp/mutations-main.md

Writes benchmarks/mutations.md (or --out) and exits non-zero if any mutation survived, could not be
applied, or broke the test run itself.  Run it before closing any issue that touches physics or
the engine; a new model (multibody, viscoelasticity, actuators) adds its own mutations here.
Each run has a private JIT cache, a copy of the user's (~/.cache/fenics): a mutated form compiles once
under its own key there, and the user's cache is left as it was.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from report import table

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PYTHON = sys.executable


@dataclass
class Mutation:
    name: str
    file: str
    edits: list          # [(old, new), ...] in `file`; each old text must occur exactly once
    tests: list          # pytest node ids (relative to the repository) that must catch it
    what: str            # the defect it stands for


M = Mutation
JOINTS_3D = "tests/models/test_joint_oracles.py::test_joint_between_two_tumbling_bodies_holds_its_definition"
COMPONENTS = "tests/models/test_components.py"
CONTROL = "tests/models/test_control.py"
JOINTS_PLANAR = "tests/models/test_joint_oracles.py::test_planar_joint_between_a_spinning_beam_and_a_body_holds_its_definition"
LINEAR_COMPONENTS = "tests/analysis/test_linearize_components.py"
CONTACT = "tests/models/test_contact.py"
ROD_CONTACT = "tests/models/test_rod_contact.py"
RIGID_ROD = "tests/models/test_rigid_rod_contact.py"
LINKING = "tests/analysis/test_linking.py"
PLECTONEME = "tests/models/test_plectoneme.py"
ROD_FRICTION = "tests/models/test_rod_friction.py"
STEPPING = "tests/analysis/test_stepping.py"
BATCH = "tests/core/test_batch.py"
KINDS = "tests/core/test_kinds.py"
PLACED = "tests/core/test_distributed_bodies.py"
THERMO = "tests/models/test_thermoelastic_string.py"
THERMO_BEAM = "tests/models/test_thermoelastic_beam.py"
ADAPTIVE = "tests/analysis/test_adaptive_systems.py"
MANY = "tests/models/test_many_scenes.py"
SIMULATOR = "tests/app/test_simulator.py"
REDUCE = "tests/analysis/test_reduce.py"
GALERKIN = "tests/analysis/test_galerkin.py"
ECSW = "tests/analysis/test_ecsw.py"
TENDON_DYN = "tests/models/test_tendon_arm_dynamic.py"
DAMPING = "tests/models/test_damping.py"
CAPSTAN = "tests/models/test_capstan.py"
GRASP = "tests/models/test_soft_arm_grasp.py"
STABILITY = "tests/analysis/test_stability.py"
RANK = "tests/la/test_rank.py"
MUTATIONS = [
    # -- planar beam ---------------------------------------------------------------------------
    M("planar-S-sign", "forms/planar_beam.py",
      [("S_HAT = ufl.as_matrix([[0.0, -1.0], [1.0, 0.0]])", "S_HAT = ufl.as_matrix([[0.0, 1.0], [-1.0, 0.0]])")],
      ["tests/models/test_planar_beam.py::test_objectivity_rigid_rotation_gives_no_strain_rate",
       "tests/models/test_planar_beam.py::test_spinning_beam_stretches_only_by_centrifugal_force"],
      "flipped sign of S: energy-consistent but not objective"),
    M("planar-locking-element", "forms/planar_beam.py",
      [('Field("Gamma", "DG", k - 1, (2,)), Field("kappa", "DG", k - 1)]',
        'Field("Gamma", "DG", k, (2,)), Field("kappa", "DG", k)]')],
      ["tests/models/test_planar_beam.py::test_no_shear_locking_slender_cantilever"],
      "strains in DG_k instead of DG_(k-1): the equal-order (locking) element"),
    M("planar-degree-ignored", "demos/_planar.py",
      [('degree=p["degree"], damping=kv)', "degree=1, damping=kv)")],
      ["tests/models/test_planar_beam.py::test_roll_up_spatial_order_grows_with_the_degree"],
      "the planar scenes ignore `degree` (P1 whatever is asked)"),
    M("planar-effort-not-projected", "forms/planar_beam.py",
      [("            N, M = Nh, Mh\n", "")],
      ["tests/models/test_planar_beam.py::test_higher_degree_keeps_the_balance"],
      "degree >= 2: pointwise discrete gradient of DG1 strains, not in the test space"),
    # -- integrators: midpoint and discrete gradient ----------------------------------------------
    M("dg-midpoint-effort", "rodfem/core/integrators.py",
      [('if self.rule == "discrete-gradient":', "if False:")],
      ["tests/models/test_planar_beam.py::test_discrete_gradient_exact_for_hyperelastic_midpoint_not",
       "tests/models/test_string.py::test_midpoint_breaks_balance_for_logarithmic_not_for_kirchhoff",
       "tests/models/test_planar_beam.py::test_no_input_conserves_energy_and_momenta"],
      "the discrete-gradient branch returns the midpoint effort"),
    M("dg-no-taylor-term", "rodfem/core/integrators.py",
      [("d3W / 24.0)", "0.0 * d3W)")],
      ["tests/models/test_planar_beam.py::test_flying_spaghetti_balance_and_momenta_after_load",
       "tests/models/test_planar_beam.py::test_discrete_gradient_exact_for_hyperelastic_midpoint_not",
       "tests/models/test_string.py::test_discrete_gradient_balance_every_material"],
      "Taylor term of the discrete gradient set to zero (balance error 8e-10 max|H|)"),
    M("dg-correction-sign", "rodfem/core/integrators.py",
      [("grad = grad + bracket /", "grad = grad - bracket /")],
      ["tests/models/test_planar_beam.py::test_no_input_conserves_energy_and_momenta",
       "tests/models/test_string.py::test_discrete_gradient_balance_every_material"],
      "wrong sign of Gonzalez' correction (invisible on quadratic W)"),
    M("midpoint-is-backward-euler", "rodfem/core/integrators.py",
      [("return 0.5 * (self.x0[name] + self.x1[name])", "return self.x1[name]")],
      ["tests/models/test_planar_beam.py::test_no_input_conserves_energy_and_momenta",
       "tests/models/test_cosserat_rod.py::test_second_order_in_time"],
      "x_{n+1/2} replaced by x_{n+1}: first order, dissipative"),
    # -- ports and engine ---------------------------------------------------------------------------
    M("port-output-at-x1", "rodfem/core/ports.py",
      [("return self._pair(step, {n: step.mid(n) for n in step.x0}) * self.measure(dx, ds)",
        "return self._pair(step, {n: step.x1[n] for n in step.x0}) * self.measure(dx, ds)")],
      ["tests/models/test_planar_beam.py::test_flying_spaghetti_balance_and_momenta_after_load",
       "tests/models/test_cosserat_rod.py::test_energy_balance_with_inputs"],
      "port output y taken at x_{n+1} instead of x_{n+1/2}"),
    M("missing-allreduce", "rodfem/core/system.py",
      [("        total = allreduce_sum(self.comm, local)\n", "        total = np.array(local, dtype=float)\n")],
      ["tests/app/test_cli.py::test_mpi_two_ranks_match_serial"],
      "scalars (H, work, observables) not summed over the ranks"),
    M("parameter-high-ignored", "rodfem/app/scene.py",
      [("bad |= value > self.high", "bad |= False")],
      ["tests/app/test_cli.py::test_bad_input_is_one_line"],
      "the upper bound of a parameter range is not checked"),
    M("set-without-equals", "rodfem/app/cli.py",
      [('        if "=" not in pair:\n'
        '            raise ParameterError(f"{option} expects NAME=VALUE (got {pair!r})")\n', "")],
      ["tests/app/test_cli.py::test_bad_input_is_one_line",
       "tests/app/test_cli.py::test_bad_input_from_the_shell_has_no_traceback"],
      "`--set NAME` without '=' ends in a traceback"),
    M("study-column-dropped", "rodfem/app/study.py",
      [('"max_balance_error_relative", "failure"]', '"max_balance_error_relative"]')],
      ["tests/analysis/test_study.py::test_csv_has_the_documented_columns"],
      "a documented column of study.csv is no longer written"),
    # -- 3D Cosserat rod --------------------------------------------------------------------------
    M("rod3d-non-objective", "forms/cosserat_rod.py",
      [("ufl.inner(frame(d) * N, dv.dx(0))", "ufl.inner(N, dv.dx(0))"),
       ("gamma_rate = frame(d).T * v.dx(0)", "gamma_rate = v.dx(0)")],
      ["tests/models/test_cosserat_rod.py::test_objectivity_under_a_superposed_rotation"],
      "spatial stress resultants (R dropped from force and strain rate): energy-consistent, not objective"),
    M("rod3d-gll-dropped", "forms/cosserat_rod.py",
      [('    return ufl.Measure("dx", domain=dx.ufl_domain(),\n'
        '                       metadata={"quadrature_rule": "GLL", "quadrature_degree": 2})',
        "    return dx")],
      ["tests/models/test_cosserat_rod.py::test_free_rod_conserves_energy_momenta_and_orthonormality"],
      "constraints and kinematics on Gauss points: orthonormality lost at the nodes"),
    M("rod3d-locking-element", "forms/cosserat_rod.py",
      [('[Field("N", "DG", 1, v3), Field("M", "DG", 1, v3)', '[Field("N", "DG", 2, v3), Field("M", "DG", 2, v3)')],
      ["tests/models/test_cosserat_rod.py::test_cantilever_tip_force_no_locking"],
      "stress resultants in DG2 with P2 kinematics: the locking (displacement-like) element"),
    M("rod3d-angular-momentum-no-directors", "forms/cosserat_rod.py",
      [('L = ufl.cross(x["r"], p) + sum(', 'L = ufl.cross(x["r"], p) + 0 * sum(')],
      ["tests/models/test_cosserat_rod.py::test_free_rod_conserves_energy_momenta_and_orthonormality",
       "tests/models/test_cosserat_rod.py::test_energy_balance_with_inputs"],
      "angular momentum without the director (rotary) part"),
    M("rod3d-moment-pairing-factor", "forms/cosserat_rod.py",
      [("return 0.5 * sum((ufl.cross(d[i], w[i]) for i in range(3)), ufl.zero(3))",
        "return 1.0 * sum((ufl.cross(d[i], w[i]) for i in range(3)), ufl.zero(3))")],
      ["tests/models/test_cosserat_rod.py::test_roll_up_converges_to_circle"],
      "end moments act twice as strongly (pairing <m, sum d_i x w_i>): balanced, but wrong"),
    M("helix-ignores-constraint", "demos/helix_3d.py",
      [('    if p["constraint"] in ("inextensible", "kirchhoff"):\n        C_N[0] = 0.0\n'
        '    if p["constraint"] in ("shear-rigid", "kirchhoff"):\n        C_N[1:] = 0.0\n', "")],
      ["tests/models/test_cosserat_rod.py::test_kirchhoff_rod_under_a_tip_force_matches_the_elastica",
       "tests/models/test_cosserat_rod.py::test_helix_constraint_parameter_zeroes_the_compliances"],
      "helix-3d ignores its `constraint` parameter"),
    M("zero-compliance-regularised", "forms/cosserat_rod.py",
      [("self.C_N, self.C_M = (np.asarray(c, dtype=float) for c in (C_N, C_M))",
        "self.C_N, self.C_M = (np.maximum(np.asarray(c, dtype=float), 1e-4) for c in (C_N, C_M))")],
      ["tests/models/test_cosserat_rod.py::test_kirchhoff_rod_under_a_tip_force_matches_the_elastica",
       "tests/models/test_cosserat_rod.py::test_zero_compliance_constrains_strain"],
      "a zero compliance replaced by a small one (penalty instead of constraint)"),
    M("rod3d-ramp-not-smooth", "demos/_rod3d.py",
      [("return value * tau**3 * (10 - 15 * tau + 6 * tau**2)", "return value * tau**2 * (3 - 2 * tau)")],
      ["tests/models/test_cosserat_rod.py::test_roll_up_converges_to_circle",
       "tests/models/test_cosserat_rod.py::test_helix_fourth_order_and_no_locking"],
      "cubic load ramp (end acceleration != 0): a load-stepping error at t_end, order 3 instead of 4"),
    # -- strings --------------------------------------------------------------------------------
    M("string-strain-rate-factor", "forms/string.py",
      [('(step.rate("C") - 2 * ufl.inner(rs, v.dx(0))) * dC', '(step.rate("C") - ufl.inner(rs, v.dx(0))) * dC')],
      ["tests/models/test_string.py::test_strain_stays_compatible",
       "tests/models/test_string.py::test_discrete_gradient_balance_every_material"],
      "d_t C = d_s r . d_s v instead of 2 d_s r . d_s v"),
    M("string-end-mass-dropped", "forms/string.py",
      [("        ends = self._lumped(ds, 0.5 * ufl.inner(x[\"v\"], x[\"v\"]))\n"
        "        return H + ends if ends is not None else H",
        "        return H")],
      ["tests/models/test_string.py::test_crane_balance_with_end_masses_and_compatibility"],
      "the kinetic energy of the end masses missing from H"),
    # -- multibody: joints and rigid bodies ------------------------------------------------------
    M("joint-reaction-sign", "rodfem/core/joint_batch.py",
      [('        r_v = np.matmul(lam[:, None, :], G)[:, 0, :]\n', '        r_v = -np.matmul(lam[:, None, :], G)[:, 0, :]\n')],
      ["tests/core/test_system.py::test_four_bar_reproduces_the_authors_reference_point",
       "tests/core/test_system.py::test_double_pendulum_keeps_link_lengths_to_round_off"],
      "the joint's reaction enters the momentum rows with the wrong sign (not power-preserving)"),
    M("joint-constraint-at-x1", "rodfem/core/joint_batch.py",
      [('        r_lam = np.matmul(G, vm[:, :, None])[:, :, 0] - dgp / h\n',
        '        r_lam = np.matmul(self.G(q1), vm[:, :, None])[:, :, 0] - dgp / h\n')],
      ["tests/core/test_system.py::test_double_pendulum_keeps_link_lengths_to_round_off",
       "tests/models/test_slider_crank.py::test_structure_is_preserved"],
      "velocity constraint with G(q_{n+1}) instead of G(q_{n+1/2}): quadratic constraints drift"),
    M("joint-jacobian-reaction-block", "rodfem/core/joint_batch.py",
      [("        return [self.QL @ lam.ravel(), G.transpose(0, 2, 1).ravel()[self.structure[1]],",
        "        return [self.QL @ lam.ravel(), 0.9 * G.transpose(0, 2, 1).ravel()[self.structure[1]],")],
      ["tests/core/test_jacobian.py::test_jacobian_is_the_derivative_of_the_residual"],
      "the Jacobian's block d r_v/d lambda = G^T scaled by 0.9 (Newton still converges, slower)"),
    M("joint-jacobian-curvature-block", "rodfem/core/joint_batch.py",
      [("                0.5 * (self.QG @ vm.ravel())[self.structure[2]],", "                0.0 * vm.ravel()[self.structure[2]],")],
      ["tests/core/test_jacobian.py::test_jacobian_is_the_derivative_of_the_residual"],
      "the Jacobian's block d r_lam/d q = 1/2 Q v_m of quadratic conditions left out"),
    M("driven-joint-work-dropped", "rodfem/core/joint_batch.py",
      [("work = -float(np.sum((lam * dgp)[self.counted])) if self.driven else 0.0", "work = 0.0")],
      ["tests/core/test_system.py::test_driven_joint_is_an_input_port"],
      "a driven joint's work -lambda . dg_p missing from the supplied work"),
    M("servo-column-is-g-transpose", "rodfem/core/servo.py",
      [("        r_v = -B @ u\n", "        r_v = -Gs.T @ u\n"),
       ("        return r_v, r_u, drv_dq, -B,", "        return r_v, r_u, drv_dq, -Gs.T,")],
      ["tests/models/test_servo.py::test_rail_crane_against_flatness",
       "tests/models/test_servo.py::test_hoisting_trolley_against_flatness"],
      "the servo's inputs act on the prescribed point itself (a driven joint's column G_s^T), not through B"),
    M("servo-work-dropped", "rodfem/core/servo.py",
      [("h * float(u @ (B.T @ vm))", "0.0")],
      ["tests/models/test_servo.py::test_replay_recovers_the_path_and_the_energy"],
      "the inputs' work h u . B^T v_m missing from the supplied work"),
    M("servo-input-map-at-x1", "rodfem/core/servo.py",
      [("        B = self.input_map(qm)\n", "        B = self.input_map(q1)\n")],
      ["tests/models/test_servo.py::test_replay_recovers_the_path_and_the_energy"],
      "the winch's direction at q_{n+1}: the balance still closes, but the inputs are not those of a load "
      "or control law read at the midpoint (the replay leaves the path)"),
    M("joint-rows-dropped-off-rank", "rodfem/core/joint_batch.py",
      [("        b.setValues(self._res_rows, self.residual_values(), addv=PETSc.InsertMode.ADD)\n",
        "        lo, hi = b.getOwnershipRange()\n"
        "        keep = (np.asarray(self._res_rows) >= lo) & (np.asarray(self._res_rows) < hi)\n"
        "        b.setValues(np.asarray(self._res_rows)[keep], self.residual_values()[keep], addv=PETSc.InsertMode.ADD)\n")],
      ["tests/core/test_system.py::test_four_bar_two_ranks_equal_serial"],
      "the joints' rows that rank 0 adds for other ranks are dropped (np2 differs or fails)"),
    M("rigid-body-director-mass", "forms/rigid_body.py",
      [("+ e * ufl.inner(step.rate(wn), dwi)", "+ 0.5 * e * ufl.inner(step.rate(wn), dwi)")],
      ["tests/core/test_system.py::test_rigid_body_spins_with_orthonormal_directors",
       "tests/models/test_slider_crank.py::test_agrees_with_the_exact_motion"],
      "rigid body: the director inertia in the balance differs from the one in H"),
    M("string-density-per-stretched-length", "forms/string.py",
      [('+ self.constants(dom)["rhoA"] * ufl.inner(step.rate("v"), dv)',
        '+ self.constants(dom)["rhoA"] / ufl.sqrt(step.mid("C")) * ufl.inner(step.rate("v"), dv)')],
      ["tests/models/test_string.py::test_wave_speed",
       "tests/models/test_string.py::test_spatial_order_of_a_vibrating_string"],
      "inertia with the mass per stretched length rhoA/sqrt(C) where rhoA is per reference length"),
    # -- larger meshes: the solvers ------------------------------------------------------------
    M("partial-lu-update-sign", "rodfem/la/partial_lu.py",
      [("w[uj[t]] -= l * ua[t];", "w[uj[t]] += l * ua[t];")],
      ["tests/la/test_scaling.py::test_partial_lu_leaves_the_schur_complement"],
      "the partial LU's elimination adds the update instead of subtracting it"),
    M("spread-functionals-without-ghost-values", "rodfem/fem/batch.py",
      [("            out[b] = float(batch.scalars(x.x.array)[0])",
        "            own = x.function_space.dofmap.index_map.size_local * x.function_space.dofmap.index_map_bs\n"
        "            out[b] = float(batch.scalars(np.where(np.arange(len(x.x.array)) < own, x.x.array, 0.0))[0])")],
      ["tests/core/test_batch.py::test_a_body_spread_over_ranks_has_the_residual_of_dolfinx"],
      "a spread body's functionals read its ghost dofs as zero (the cells at the ranks' border wrong)"),
    M("subgraph-keeps-the-left-out-columns", "rodfem/la/partial_lu.py",
      [("      if (id[gj[p]] >= 0) sj[nnz++] = id[gj[p]];", "      sj[nnz++] = id[gj[p]] >= 0 ? id[gj[p]] : 0;")],
      ["tests/la/test_scaling.py::test_a_subgraph_is_scipys_rows_and_columns_of_the_graph"],
      "the orders' graph keeps the edges to the dofs left out (next to the interface), on dof 0"),
    M("near-interface-rows-only", "rodfem/la/partial_lu.py",
      [("        near[cols[cols < nI]] = True\n", "")],
      ["tests/la/test_scaling.py::test_the_dofs_next_to_the_interface_are_ordered_last"],
      "the interior dofs an interface row couples to are ordered with the rest, not last (more fill)"),
    M("partial-structure-interface-values-from-the-diagonal-block", "rodfem/la/schur.py",
      [("            src = np.insert(src, ends, nD + np.flatnonzero(okeep))",
        "            src = np.insert(src, ends, np.flatnonzero(okeep))")],
      ["tests/la/test_scaling.py::test_mpi_two_ranks_at_ten_thousand_elements"],
      "an interior row's entries in other ranks' interface columns take values of the rank's own block"),
    M("schur-corner-sign", "rodfem/la/schur.py",
      [("self.S = self.A_GG + sums[:-1].reshape(self.nG, self.nG)",
        "self.S = self.A_GG - sums[:-1].reshape(self.nG, self.nG)")],
      ["tests/la/test_scaling.py::test_mpi_two_ranks_at_ten_thousand_elements"],
      "the ranks' Schur terms subtracted: the interface solve is wrong under mpirun"),
    M("schur-backward-without-interface", "rodfem/la/schur.py",
      [("self.plu.backward(xG, out)", "self.plu.backward(np.zeros_like(xG), out)")],
      ["tests/la/test_scaling.py::test_mpi_two_ranks_at_ten_thousand_elements"],
      "the interiors' back-substitution ignores the interface values x_G"),
    M("lu-chain-skips-partial-lu", "rodfem/la/lu_chain.py",
      [("following = names[names.index(failed) + 1]", "following = names[min(names.index(failed) + 2, len(names) - 1)]")],
      ["tests/la/test_scaling.py::test_serial_lu_chain"],
      "after RCM's zero pivot the serial LU skips the partial LU (then SuperLU: 4x slower on the 3D rod)"),
    M("multipliers-not-postponed", "rodfem/la/schur.py",
      [('postpone=(diagonal.array if K["interior"] is None\n'
        '                                               else diagonal.array[K["interior"]]) == 0)', "postpone=None)")],
      ["tests/la/test_scaling.py::test_schur_pc_solves_like_lu_in_serial", "tests/la/test_scaling.py::test_serial_lu_chain"],
      "the partial LU orders the multipliers with the rest: zero pivots, MUMPS after every order"),
    M("interface-without-multipliers", "rodfem/la/schur.py",
      [("G = self._with_multipliers(A, G, lo, di, dj, orows, ocols)", "pass")],
      ["tests/la/test_scaling.py::test_mpi_three_ranks_3d_rod_matches_serial"],
      "an interface node's multipliers stay in the interior, whose block is then singular (MUMPS on the whole matrix)"),
    M("postponed-after-any-neighbour", "rodfem/la/partial_lu.py",
      [("pairs = K.multiply(K.T).tocsr()", "pairs = graph")],
      ["tests/la/test_scaling.py::test_serial_lu_chain_on_harder_saddle_points"],
      "a multiplier placed after a neighbour that gives its pivot nothing (K_kz = 0): zero pivot on a thin section"),
    M("serial-schur-keeps-its-mumps", "rodfem/la/schur.py",
      [("        if self.comm.size == 1:   # a stage of Newton's serial LU chain: the pivoting LUs come next there\n"
        "            return False\n", "")],
      ["tests/la/test_scaling.py::test_serial_lu_chain_on_harder_saddle_points"],
      "in serial the partial LU ends in its own MUMPS stage instead of handing over to SuperLU (7x slower on a viscoelastic rod)"),
    M("newton-failure-blames-the-lu", "rodfem/nls/newton.py",
      [("return not e > ACCURATE_LU", "return False")],
      ["tests/nls/test_newton.py::test_a_step_too_large_for_newton_keeps_the_partial_lu"],
      "a step too large for Newton hands the partial LU over to SuperLU for the rest of the run (3x slower)"),
    M("backward-error-unsigned", "rodfem/la/lu_chain.py",
      [("        r.axpy(-1.0, b)\n", "")],
      ["tests/nls/test_newton.py::test_backward_error_tells_a_small_pivot_from_an_accurate_factor"],
      "the backward error measures |A x| instead of |A x - b|: every factor looks inaccurate"),
    M("no-default-initial", "rodfem/core/body.py",
      [('(model.default_initial() if hasattr(model, "default_initial") else {})', "{}")],
      ["tests/core/test_system.py::test_a_body_placed_without_initial_values_is_straight_at_rest[beam]",
       "tests/core/test_system.py::test_a_body_placed_without_initial_values_is_straight_at_rest[rod]"],
      "a body placed without initial values starts at q = 0 (a rod of zero length: singular, or compressed to a point)"),
    M("field-values-ghosts", "rodfem/core/system.py",
      [("index.append(blk.lo + dofs[dofs < blk.hi - blk.lo])", "index.append(blk.lo + dofs)")],
      ["tests/core/test_system.py::test_field_values_are_every_bodys_nodal_values",
       "tests/core/test_system.py::test_field_values_of_a_rod_split_over_ranks_count_each_node_once"],
      "System.field_values keeps every local dof of a body (a rank's ghosts counted twice, or another body's values read)"),
    M("grown-pattern-not-reread", "rodfem/fem/assembly.py",
      [("if state != self._state:", "if False:")],
      ["tests/fem/test_assembly.py::test_fast_assembly_inserts_an_entry_outside_its_pattern"],
      "after an entry was inserted the assembly keeps the old structure (stale arrays)"),
    M("block-row-offset-ignored", "rodfem/fem/assembly.py",
      [("self.fast.attach(A, self.lo, self.l2g, shared)", "self.fast.attach(A, 0, self.l2g, shared)")],
      ["tests/core/test_system.py::test_four_bar_reproduces_the_authors_reference_point",
       "tests/models/test_mb_scenes.py::test_crane_payload_balance_joint_orthonormality_and_motion"],
      "every body's Jacobian block added at the first body's rows (the block offset dropped)"),
    M("ghost-columns-misplaced", "rodfem/fem/assembly.py",
      [("base = block_start[owners] + (ghosts - starts[owners]) * bs", "base = block_start[owners] + ghosts * bs")],
      ["tests/core/test_system.py::test_four_bar_two_ranks_equal_serial",
       "tests/la/test_scaling.py::test_mpi_three_ranks_3d_rod_matches_serial"],
      "a body's ghost dofs mapped to the wrong global columns (only under mpirun, ghosts owned by rank >= 1)"),
    M("failed-newton-keeps-last-iterate", "rodfem/nls/newton.py",
      [("            self.assembler.update(self._start)   # x back to the initial guess, not the last iterate\n", "")],
      ["tests/nls/test_newton.py::test_a_failure_names_the_step_and_leaves_x_alone"],
      "a failed Newton leaves x at its last iterate (possibly NaN) instead of the initial guess"),
    M("discrete-gradient-not-symmetric", "rodfem/core/integrators.py",
      [("Xm = ufl.variable(0.5 * (X0 + X1))", "Xm = ufl.variable(0.4 * X0 + 0.6 * X1)")],
      ["tests/core/test_integrators.py"],
      "the discrete gradient's base point off the midpoint: still exact in energy, not symmetric (first order)"),
    # -- independent oracles (issue 22): wrong but consistent physics ----------------------------------
    M("planar-rigid-inertia-scaled", "forms/rigid_body.py",
      [("ParameterSet(m=float(mass), J=float(inertia))", "ParameterSet(m=float(mass), J=1.001 * float(inertia))")],
      ["tests/models/test_rigid_bodies.py::test_planar_body_under_constant_force_and_moment"],
      "the planar rigid body's inertia 0.1 % off in H and in the balance alike (energy-consistent)"),
    M("linearization-without-geometric-stiffness", "rodfem/analysis/linearize.py",
      [("M[vi[r], qi[cq]] -= lamQ[r, cq]", "pass")],
      ["tests/analysis/test_modes_oracles.py"],
      "the joints' geometric stiffness lambda . Q left out of the linear model (a hanging pendulum has no modes)"),
    M("planar-outputs-without-branches", "forms/planar_beam.py",
      [('Nj, Mj = self._stress(b.spring, x[f"Gamma_{j}"], x[f"kappa_{j}"])\n            N, M = N + Nj, M + Mj',
        'Nj, Mj = self._stress(b.spring, x[f"Gamma_{j}"], x[f"kappa_{j}"])')],
      ["tests/io/test_output.py::test_planar_stress_resultants_include_the_maxwell_branches"],
      "the exported N, M of the planar beam leave the Maxwell branches out"),
    M("static-multipliers-not-fitted", "rodfem/analysis/statics.py",
      [("                self._fit_multipliers()\n", "")],
      ["tests/analysis/test_modes_oracles.py"],
      "statics starts Newton at lambda = 0: a mechanism held only by its joints has a singular tangent"),
    M("static-joint-readout-clock", "rodfem/analysis/statics.py",
      [("            points.step(self.target.X0, t, t, points.times[2])\n", "            pass\n")],
      ["tests/analysis/test_statics.py::test_a_driven_joint_holds_its_drive_in_statics"],
      "after a static solve the joints are read out with the time-stepping clock (|g_p(t)| reported)"),
    M("static-drive-sign", "rodfem/analysis/statics.py",
      [("j.e - self.mu * j.prescribed(self.t)", "j.e + self.mu * j.prescribed(self.t)")],
      ["tests/analysis/test_statics.py::test_a_driven_joint_holds_its_drive_in_statics"],
      "a driven joint's static row with the drive's sign flipped (the hub at -theta)"),
    M("solvers-left-to-petsc-finalize", "rodfem/nls/newton.py",
      [("@atexit.register   # registered after petsc4py's finalization, so it runs before it\ndef _destroy_solvers",
        "def _destroy_solvers")],
      ["tests/core/test_system.py::test_two_point_masses_under_a_domain_load_follow_the_closed_form"],
      "a script's parallel solver left to PETSc's finalization (SEGV at exit under mpirun)"),
    M("point-mass-2d-angular-momentum-sign", "forms/rigid_body.py",
      [('out["L_z"] = x["x"][0] * p[1] - x["x"][1] * p[0]', 'out["L_z"] = x["x"][1] * p[0] - x["x"][0] * p[1]')],
      ["tests/core/test_system.py::test_two_point_masses_under_a_domain_load_follow_the_closed_form"],
      "the 2D point mass's angular momentum with its sign flipped (a read-out: the balance does not see it)"),
    M("rigid-3d-principal-axes-swapped", "forms/rigid_body.py",
      [("        self.E = director_masses(J)\n", "        self.E = director_masses(J[::-1])\n")],
      ["tests/models/test_rigid_bodies.py::test_free_symmetric_top_precesses_at_eulers_rate"],
      "the 3D rigid body's inertia about d1 and d3 swapped (energy-consistent, a wrong precession)"),
    M("schur-column-stage-sign", "rodfem/la/schur.py",
      [("y = y - self.Z @ xG[self.ZG]", "y = y + self.Z @ xG[self.ZG]")],
      ["tests/la/test_scaling.py::test_mpi_every_interior_solver_gives_the_serial_history"],
      "the parallel solver's SuperLU/MUMPS interior stages add the interface's correction (only the default "
      "stage ran under mpirun)"),
    M("rod-branch-first-compliance-only", "forms/cosserat_rod.py",
      [("        parts[name] = c\n", "        parts[name] = np.full(3, c[0])\n")],
      ["tests/models/test_viscoelastic.py::test_anisotropic_rod_branch_creeps_per_component"],
      "a 3D Maxwell branch built from its first compliance only (isotropic tests cannot see it)"),
    M("section-start-cap-inward", "rodfem/io/sections.py",
      [("polys = [np.arange(m)[::-1]] + polys", "polys = [np.arange(m)] + polys")],
      ["tests/io/test_output.py::test_section_caps_face_outwards_and_carry_their_end_values"],
      "the section surface's start cap wound the other way (its normal facing into the rod)"),
    M("section-caps-swapped", "rodfem/io/frames.py",
      [("order = np.concatenate([[seg[0]] * cap, order, [seg[-1]] * cap])",
        "order = np.concatenate([[seg[-1]] * cap, order, [seg[0]] * cap])")],
      ["tests/io/test_output.py::test_section_caps_face_outwards_and_carry_their_end_values"],
      "each cap of the section surface carries the other end's values"),
    # -- joints between moving bodies (issue 22) --
    M("prismatic-reference-guide", "forms/joints.py",
      [("        return [*locked_rotation(a, b, a0, b0),\n"
        "                (b.x - a.x) @ a.d[j] - r0 @ a0.d[j], (b.x - a.x) @ a.d[k] - r0 @ a0.d[k]]",
        "        return [*locked_rotation(a, b, a0, b0),\n"
        "                (b.x - a.x) @ a0.d[j] - r0 @ a0.d[j], (b.x - a.x) @ a0.d[k] - r0 @ a0.d[k]]")],
      [f"{JOINTS_3D}[prismatic-axis0-gravity]", f"{JOINTS_3D}[prismatic-axis2-free]"],
      "the prismatic pair's guide along a's initial directors a0.d, not its current ones (a slide "
      "along a turned guide leaves the line; with the ground as a nothing changes)"),
    M("revolute-hinge-fixed-in-space", "forms/joints.py",
      [("        return [*spherical(a, b, a0, b0), a.d[axis] @ s[j], a.d[axis] @ s[k]]",
        "        return [*spherical(a, b, a0, b0), a0.d[axis] @ s[j], a0.d[axis] @ s[k]]")],
      [f"{JOINTS_3D}[revolute-axis0-gravity]", f"{JOINTS_3D}[revolute-axis2-free]"],
      "the revolute's hinge axis stays where it started in space instead of turning with a"),
    M("cylindrical-turns-about-b-axis", "forms/joints.py",
      [("        s = _carried(b, _relative_rotation(a0, b0).T)     # R_b C^T: a's frame as b carries it\n"
        "        r0 = b0.x - a0.x\n        return [a.d[axis] @ s[j], a.d[axis] @ s[k],",
        "        t = _carried(a, _relative_rotation(a0, b0))\n"
        "        r0 = b0.x - a0.x\n        return [b.d[axis] @ t[j], b.d[axis] @ t[k],")],
      [f"{JOINTS_3D}[cylindrical-axis0-gravity]", f"{JOINTS_3D}[cylindrical-axis2-free]"],
      "the cylindrical pair as it was: b turns about its own d_axis but slides along a's (two axes "
      "when they do not start aligned)"),
    M("universal-a-axis-fixed-in-space", "forms/joints.py",
      [("_axis(a, axis_a) @ _axis(b, axis_b)", "_axis(a0, axis_a) @ _axis(b, axis_b)")],
      [f"{JOINTS_3D}[universal-axis0-gravity]", f"{JOINTS_3D}[universal-axis2-free]"],
      "the universal joint's axis on a stays where it started in space instead of turning with a"),
    M("locked-rotation-fixed-in-space", "forms/joints.py",
      [("    t = _carried(a, _relative_rotation(a0, b0))\n    return [b.d[0] @ t[1]",
        "    t = _carried(a0, _relative_rotation(a0, b0))\n    return [b.d[0] @ t[1]")],
      [f"{JOINTS_3D}[locked_rotation-axis0-gravity]", f"{JOINTS_3D}[rigid-axis2-free]", f"{JOINTS_3D}[prismatic-axis0-gravity]"],
      "the locked rotation holds b's frame fixed in space, not relative to a's turning frame"),
    M("distance-linearized", "forms/joints.py",
      [("(b.x - a.x) @ (b.x - a.x) - (b0.x - a0.x) @ (b0.x - a0.x)",
        "(b.x - a.x) @ (b0.x - a0.x) - (b0.x - a0.x) @ (b0.x - a0.x)")],
      [f"{JOINTS_3D}[distance-axis0-gravity]", f"{JOINTS_3D}[distance-axis2-free]"],
      "the distance joint linearized at t = 0: it holds the offset's projection on its initial "
      "direction, not its length (right until the link turns)"),
    M("planar-rigid-angle-sum", "forms/joints.py",
      [("return [*(a.x - b.x), (b.phi - a.phi) - (b0.phi - a0.phi)]",
        "return [*(a.x - b.x), (b.phi + a.phi) - (b0.phi + a0.phi)]")],
      [f"{JOINTS_PLANAR}[planar_rigid-beam-at-0.6rad]", f"{JOINTS_PLANAR}[planar_rigid-beam-at-2.4rad]"],
      "the planar weld holds the sum of the angles, not their difference (b turns against a)"),

    # -- restart of dissipating and actuated scenes (issue 22) --
    M("checkpoint-without-dissipated", "rodfem/io/checkpoint.py",
      [("                dissipated=dissipated, control_states=_control_states(problem),",
        "                dissipated=0.0, control_states=_control_states(problem),")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-cantilever-2d-killed-two-steps-after-a-checkpoint]",
       "tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[driven-hub-arm-killed-two-steps-after-a-checkpoint]"],
      "the checkpoint stores dissipated = 0: a resumed viscoelastic run reports only what it dissipated after the restart"),
    M("resume-drops-the-frame-at-the-checkpoint", "rodfem/io/checkpoint.py",
      [("if tf <= t * (1 + 1e-12) + 1e-300:", "if tf < t * (1 - 1e-12):")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-cantilever-2d-killed-two-steps-after-a-checkpoint]"],
      "a resumed run drops the frame at the checkpoint's time from the .pvd (the later frames take its file)"),
    M("resume-renumbers-the-frames", "rodfem/io/checkpoint.py",
      [("                self.frames = sorted(kept.items())\n", "                self.frames = []\n")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-string-killed-two-steps-after-a-checkpoint]"],
      "a resumed run numbers its frames from 0 again: it overwrites the first frame files, the .pvd loses the earlier ones"),
    M("restore-skips-the-maxwell-branches", "rodfem/io/checkpoint.py",
      [("            what = f\"field {f.name} of body {bname or 'the scene'}\"\n",
        "            what = f\"field {f.name} of body {bname or 'the scene'}\"\n"
        "            if f.name[-2:] == \"_1\":   # the Maxwell branch's strain: left as built (relaxed)\n"
        "                continue\n")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-string-killed-two-steps-after-a-checkpoint]",
       "tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-cantilever-3d-killed-two-steps-after-a-checkpoint]"],
      "the restart leaves the Maxwell branches' internal strains (C_1, Gamma_1, kappa_1, M_1) relaxed, not as checkpointed"),
    M("first-resumed-step-with-the-initial-inputs", "rodfem/analysis/timeloop.py",
      [("        return attempt(problem, state, h, t, t1, previous, ratio, step, dissipates)\n",
        "        if start is not None and step == first + 1:   # the rebuilt scene's inputs u(0) in the first step after a restart\n"
        "            set_time, problem.set_time = problem.set_time, lambda time: None\n"
        "            try:\n"
        "                return attempt(problem, state, h, t, t1, previous, ratio, step, dissipates)\n"
        "            finally:\n"
        "                problem.set_time = set_time\n"
        "        return attempt(problem, state, h, t, t1, previous, ratio, step, dissipates)\n")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[soft-arm-swing-killed-two-steps-after-a-checkpoint]"],
      "the chamber's pressure and the tendon's tension of the first step after a restart not set from the restored clock"),
    M("restart-without-the-newton-predictor", "rodfem/io/checkpoint.py",
      [('previous = vector("previous") if meta.get("has_previous") else None', "previous = None")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run[viscoelastic-cantilever-2d-killed-two-steps-after-a-checkpoint]"],
      "the restart drops x_{n-1}: Newton starts from x_n, the resumed run differs at Newton's tolerance, not to the bit"),
    # -- components and controllers (issue 23) --
    M("component-dg-is-midpoint", "rodfem/core/components.py",
      [("        z = grad + (bracket / n2 if n2 > 0 else 0.0) * dxi\n",
        "        z = grad\n")],
      [f"{COMPONENTS}::test_discrete_gradient_balance_to_round_off_and_momenta_conserved[hookean]",
       f"{COMPONENTS}::test_discrete_gradient_balance_to_round_off_and_momenta_conserved[tension-only]"],
      "a spring's discrete gradient without Gonzalez' correction (the gradient at the mean measure: "
      "exact for the quartic spring, quadratic in c, not for the Hookean one)"),
    M("damper-dissipation-halved", "rodfem/core/components.py",
      [("return r_v, dr_dq, dr_dv, 0.0, h * eta * float(rate @ rate)",
        "return r_v, dr_dq, dr_dv, 0.0, 0.5 * h * eta * float(rate @ rate)")],
      [f"{COMPONENTS}::test_mass_on_a_spring_follows_the_midpoint_recurrence[damper-midpoint]"],
      "a damper books half the energy it takes out in `dissipated`"),
    M("dashpot-coefficient-not-normalized", "forms/components.py",
      [("lambda length2: c / (4.0 * length2)", "lambda length2: c / 4.0")],
      [f"{COMPONENTS}::test_mass_on_a_spring_follows_the_midpoint_recurrence[dashpot-midpoint]"],
      "the dashpot's coefficient not divided by |d|^2: a length-dependent damping, energy-consistent"),
    M("moving-set-point-work-dropped", "rodfem/core/components.py",
      [("            work = (after(xi1) - psi(xi1)) + (psi(xi0) - before(xi0))",
        "            work = 0.0 * ((after(xi1) - psi(xi1)) + (psi(xi0) - before(xi0)))")],
      [f"{CONTROL}::test_robot_arm_reaches_the_set_angle_and_stops_vibrating"],
      "a PD's moving set point supplies work that is not booked (balance off while it moves)"),
    M("control-law-rate-at-x1", "rodfem/core/components.py",
      [("        xim, rate = self.xi(qm), Gm @ vm\n        u = self.u(tm, xim, rate, h)",
        "        xim, rate = self.xi(qm), Gm @ v1\n        u = self.u(tm, xim, rate, h)")],
      [f"{CONTROL}::test_pd_on_a_wheel_follows_the_recurrence[midpoint-law]"],
      "a Python control law reads the rate at t_{n+1}, not the midpoint (first order, its work wrong)"),
    M("pid-integral-not-advanced", "forms/components.py",
      [("        self.state = [self.state[0] + h * (xi - self.r(t))]", "        self.state = list(self.state)")],
      [f"{CONTROL}::test_pid_rejects_a_constant_disturbance_by_the_recurrence[pid]"],
      "the PID's integral never advances (a PD with a constant offset)"),
    M("checkpoint-without-control-states", "rodfem/io/checkpoint.py",
      [("            c.law.state = [float(x) for x in saved[c.name]]", "            pass")],
      ["tests/io/test_restart.py::test_every_file_of_a_resumed_dissipating_or_actuated_run"
       "[robot-arm-control-killed-two-steps-after-a-checkpoint]"],
      "a resumed PID run starts its integral from zero"),
    M("springs-not-in-statics", "rodfem/analysis/statics.py",
      [('if (target.joints or getattr(target, "components", None)) else None', "if target.joints else None")],
      [f"{COMPONENTS}::test_spring_damper_chain_statics_against_the_column_equations[hookean]"],
      "statics leaves out the springs of a system without joints"),



    # -- linear models with components (issue 23) --
    M("linear-spring-without-geometric-stiffness", "rodfem/core/components.py",
      [('stiffness = G.T @ psi.hessian(xi, order=4) @ G + np.einsum("k,kij->ij", z, self.Q)',
        "stiffness = G.T @ psi.hessian(xi, order=4) @ G")],
      [f"{LINEAR_COMPONENTS}::test_taut_chain_frequencies[hookean]",
       f"{LINEAR_COMPONENTS}::test_taut_chain_frequencies[quartic]"],
      "a spring's linear stiffness without the geometric stiffness sum psi'_k Q_k of its pre-stress (no "
      "transverse stiffness T/l, a wrong axial one)"),
    M("linear-damper-missing-from-R", "rodfem/core/components.py",
      [('"dv": eta * G.T @ G, "hessian": None}', '"dv": 0.0 * G.T @ G, "hessian": None}')],
      [f"{LINEAR_COMPONENTS}::test_damped_mass_spring_eigenvalues",
       f"{LINEAR_COMPONENTS}::test_pd_wheel_eigenvalues[pd_as_components]"],
      "the dampers left out of the linear model (R = 0: undamped modes)"),
    M("linear-feedback-without-rate-gain", "rodfem/core/components.py",
      [('"dv": -G.T @ du_drate @ G, "hessian": None,', '"dv": 0.0 * du_drate[0, 0] * G.T @ G, "hessian": None,')],
      [f"{LINEAR_COMPONENTS}::test_pd_wheel_eigenvalues[pd_in_python]",
       f"{LINEAR_COMPONENTS}::test_a_law_that_feeds_energy_in_is_not_passive"],
      "a control law's linearization without du/dxi' (the D of a PD law in Python lost)"),
    M("linear-components-at-time-zero", "rodfem/analysis/linearize.py",
      [("terms = c.linear(q, v, self.t)", "terms = c.linear(q, v, 0.0)")],
      [f"{LINEAR_COMPONENTS}::test_a_moving_set_point_is_read_at_the_linearization_time[pd_as_components]",
       f"{LINEAR_COMPONENTS}::test_a_moving_set_point_is_read_at_the_linearization_time[pd_in_python]"],
      "timed energies and control laws read at t = 0, not at the time of the linearization (a moving set point)"),

    # -- tendons on converging and helical routings (issue 22) ------------------------------------------
    M("tendon-planar-slope-dropped", "forms/actuators.py",
      [("Gamma[1] + dy[0]])", "Gamma[1]])")],
      ["tests/models/test_tendon_routings.py::test_planar_tendon_on_a_converging_routing_matches_rucker_webster",
       "tests/models/test_tendon_routings.py::test_planar_default_element_converges_to_rucker_webster"],
      "the planar fibre tangent without the routing's slope y' (in the length and its gradient alike: a tapering "
      "tendon neither tilts nor shears the beam)"),
    M("tendon-rod-slope-sign", "forms/actuators.py",
      [("ufl.cross(K, y3) + dy3", "ufl.cross(K, y3) - dy3")],
      ["tests/models/test_tendon_routings.py::test_rod_tendon_on_converging_and_helical_routings_matches_rucker_webster"],
      "the 3D fibre tangent with the routing's slope y' subtracted (a consistent length of the mirrored routing)"),
    M("tendon-converging-slope-halved", "forms/actuators.py",
      [('[-c["offset"][i] / c["length"] + 0.0 * s', '[-0.5 * c["offset"][i] / c["length"] + 0.0 * s')],
      ["tests/models/test_tendon_routings.py::test_planar_tendon_on_a_converging_routing_matches_rucker_webster",
       "tests/models/test_tendon_routings.py::test_rod_tendon_on_converging_and_helical_routings_matches_rucker_webster"],
      "the converging routing's y' half its slope (y and y' disagree; straight routings cannot see it)"),
    M("tendon-helical-slope-reversed", "forms/actuators.py",
      [("[-R * k * lib.sin(a), R * k * lib.cos(a)]", "[R * k * lib.sin(a), -R * k * lib.cos(a)]")],
      ["tests/models/test_tendon_routings.py::test_rod_tendon_on_converging_and_helical_routings_matches_rucker_webster"],
      "the helical routing's y' turning the other way round than its y"),
    M("tendon-end-ignored", "forms/actuators.py",
      [("self.segment = (0.0, float(self.end))", "self.segment = None")],
      ["tests/models/test_tendon_routings.py::test_planar_tendon_on_a_converging_routing_matches_rucker_webster",
       "tests/models/test_tendon_routings.py::test_rod_tendon_on_converging_and_helical_routings_matches_rucker_webster"],
      "a tendon's end s_end ignored: it runs on to the tip (the balance of the longer tendon is exact)"),

    # -- contact and friction (issue 24) ---------------------------------------------------------
    M("contact-midpoint-effort", "rodfem/core/integrators.py",
      [('        if self.rule != "discrete-gradient":\n            A = ufl.variable(am)',
        '        if True:\n            A = ufl.variable(am)')],
      [f"{CONTACT}::test_string_falling_on_an_obstacle_keeps_the_balance[plane]",
       f"{CONTACT}::test_string_falling_on_an_obstacle_keeps_the_balance[sphere]"],
      "a distributed contact's co-energy psi'(g(x_m)) under the discrete gradient (not the difference quotient)"),
    M("contact-friction-not-booked", "forms/contact.py",
      [("        if self.friction is None:\n            return None\n        z, grad = self._step_terms(step)",
        "        if True:\n            return None\n        z, grad = self._step_terms(step)")],
      [f"{CONTACT}::test_string_falling_on_an_obstacle_keeps_the_balance[plane-friction]",
       f"{CONTACT}::test_rolling_rod_energies_follow_the_analytic_solution[sliding]"],
      "the friction's work left out of `dissipated` (distributed contact)"),
    M("contact-friction-ignores-spin", "forms/contact.py",
      [('            return section_point_velocity(v, [-r * ufl.inner(n, x[d]) for d in DIRECTORS[1:]], [w[wi] for wi in RATES[1:]])',
        "            return v")],
      [f"{CONTACT}::test_rolling_rod_energies_follow_the_analytic_solution[rolling]"],
      "friction at the centreline, not at the rod's surface: it neither spins the rod nor lets it roll"),
    M("contact-point-friction-not-booked", "rodfem/core/components.py",
      [("        return r_v, dr_dq, dr_dv, 0.0, h * max(power, 0.0)", "        return r_v, dr_dq, dr_dv, 0.0, 0.0")],
      [f"{CONTACT}::test_block_slides_down_the_incline_with_the_coulomb_deceleration"],
      "a Dissipator's (point friction's) work left out of `dissipated`"),
    M("contact-penalty-quadratic", "forms/contact.py",
      [("            return k / 3.0 * ufl.conditional(ufl.lt(g, 0.0), -g, 0.0) ** 3",
        "            return k / 2.0 * ufl.conditional(ufl.lt(g, 0.0), -g, 0.0) ** 2")],
      [f"{CONTACT}::test_rolling_rod_energies_follow_the_analytic_solution[rolling]"],
      "the distributed penalty k/2 <-g>^2 instead of k/3 <-g>^3: the rod sinks to the wrong depth"),

    # -- contact between rods and self-contact (issue 24) ------------------------------------------
    M("rodcontact-no-dg-correction", "rodfem/core/bodycontact.py",
      [("        c = np.where(use, bracket / np.where(use, nP2, 1.0), 0.0)", "        c = 0.0 * bracket")],
      [f"{ROD_CONTACT}::test_the_step_force_does_the_energy_change_with_no_net_force_or_moment[discrete-gradient]",
       f"{ROD_CONTACT}::test_collision_keeps_momentum_and_energy[discrete-gradient]"],
      "the rod contact's force without the discrete gradient's correction: grad d(x_m) times the quotient"),
    M("rodcontact-unprojected-correction", "rodfem/core/bodycontact.py",
      [("        P = rigid_projection(dX, Xm)", "        P = dX")],
      [f"{ROD_CONTACT}::test_the_step_force_does_the_energy_change_with_no_net_force_or_moment[discrete-gradient]",
       f"{ROD_CONTACT}::test_collision_keeps_momentum_and_energy[discrete-gradient]"],
      "Gonzalez's correction along dX itself (not projected off the rigid motions): energy exact, momenta not"),
    M("rodcontact-quotient", "forms/rod_contact.py",
      [("-self.k / 3.0 * (p0 * p0 + p0 * p1 + p1 * p1)", "-self.k / 3.0 * (p0 * p0 + 2 * p0 * p1) ")],
      [f"{ROD_CONTACT}::test_the_step_force_does_the_energy_change_with_no_net_force_or_moment[discrete-gradient]",
       f"{ROD_CONTACT}::test_collision_keeps_momentum_and_energy[discrete-gradient]"],
      "a wrong difference quotient of the cubic penalty while the contact lasts through the step"),
    M("rodcontact-unclamped-closest-point", "forms/rod_contact.py",
      [("    b = np.clip(b, 0.0, 1.0)\n", "")],
      [f"{ROD_CONTACT}::test_segment_distance_against_a_brute_force_search"],
      "the closest point on the second segment left unclamped (a point of its line beyond the segment)"),
    M("rodcontact-broad-phase-radius", "rodfem/core/bodycontact.py",
      [("    pairs = tree.query_pairs(2.0 * float(np.max(radii)), output_type=\"ndarray\")",
        "    pairs = tree.query_pairs(float(np.max(radii)), output_type=\"ndarray\")")],
      [f"{ROD_CONTACT}::test_broad_phase_finds_every_overlap_and_stays_linear"],
      "the k-d tree searched within max r instead of 2 max r: overlapping spheres missed"),
    M("rodcontact-no-self-exclusion", "rodfem/core/bodycontact.py",
      [("            return pairs[(sep >= self.law.exclude) & (pairs[:, 1] > pairs[:, 0] + 1)]",
        "            return pairs[(pairs[:, 1] > pairs[:, 0] + 1)]")],
      [f"{ROD_CONTACT}::test_self_contact_leaves_out_the_rods_own_neighbourhood"],
      "self-contact without the exclusion length: a straight rod of short segments touches itself"),
    M("rodcontact-energy-not-in-H", "rodfem/core/system.py",
      [("            stored += self.body_contacts.energy(self.X1)", "            stored += 0.0")],
      [f"{ROD_CONTACT}::test_collision_keeps_momentum_and_energy[discrete-gradient]",
       f"{ROD_CONTACT}::test_self_contact_stops_a_hairpin_from_passing_through_itself"],
      "the rods' contact energy left out of H"),
    M("rodcontact-zone-unweighted", "rodfem/core/bodycontact.py",
      [("        return wa * wb * np.ones(len(pairs))", "        return np.ones(len(pairs))")],
      [f"{ROD_CONTACT}::test_segment_pairs_sharing_the_contact_zone_converge_to_the_double_integral"],
      "segments shorter than the contact zone not sharing it: the contact stiffens with the mesh"),
    M("rodcontact-one-sided-force", "rodfem/core/bodycontact.py",
      [("        w = np.stack([1.0 - a, a, b - 1.0, -b], axis=1)", "        w = np.stack([1.0 - a, a, 0.0 * b, 0.0 * b], axis=1)")],
      [f"{ROD_CONTACT}::test_the_step_force_does_the_energy_change_with_no_net_force_or_moment[discrete-gradient]",
       f"{ROD_CONTACT}::test_rod_resting_across_clamped_rods_carries_its_weight[lever]"],
      "the contact force on one body only (no reaction on the other)"),
    M("rodcontact-guard-end-gap-only", "rodfem/core/bodycontact.py",
      [("                margin = 0.5 * (p.distance(X0) + p.distance(X1) - s) / max(p.R, 1e-300)",
        "                margin = 0.5 * (p.distance(X0) + p.distance(X1)) / max(p.R, 1e-300)")],
      [f"{ROD_CONTACT}::test_a_step_that_would_pass_the_rods_through_each_other_is_split"],
      "the step's guard on the gaps at x_n and x_n+1 only (not the relative motion): a step tunnelling through passes"),

    # -- the plectoneme: link, twist, writhe and the turned end (issue 24) --------------------------
    M("plectoneme-wall-through-clamp", "demos/plectoneme.py",
      [('Contact(Plane((1.0, 0.0, 0.0), (-p["r"], 0.0, 0.0))', 'Contact(Plane((1.0, 0.0, 0.0), (0.0, 0.0, 0.0))')],
      [f"{PLECTONEME}::test_below_buckling_the_rod_twists_straight"],
      "the clamp's wall through the clamped node (not the tube's surface): it pushes the rod's end away"),
    M("writhe-unsigned", "rodfem/analysis/linking.py",
      [("    sign = np.where(np.abs(volume) > 1e-12 * size, np.sign(volume), 0.0)", "    sign = np.where(np.abs(volume) > 1e-12 * size, 1.0, 0.0)")],
      [f"{LINKING}::test_planar_curves_have_no_writhe", f"{LINKING}::test_helix_writhe_twist_and_link"],
      "the segment pairs' solid angles summed without their sign: the writhe of a mirror image unchanged"),
    M("writhe-coplanar-noise", "rodfem/analysis/linking.py",
      [("    sign = np.where(np.abs(volume) > 1e-12 * size, np.sign(volume), 0.0)", "    sign = np.sign(volume)")],
      [f"{LINKING}::test_planar_curves_have_no_writhe"],
      "coplanar segment pairs (collinear leads and closure) counted with the noise of their normals"),
    M("twist-no-transport", "rodfem/analysis/linking.py",
      [("    carried = _transport(u[:-1], t[:-1], t[1:])", "    carried = u[:-1]")],
      [f"{LINKING}::test_helix_writhe_twist_and_link"],
      "the ribbon compared edge to edge without the parallel transport: Tw of a helix wrong"),
    M("twist-angle-sign", "rodfem/analysis/linking.py",
      [("    angle = np.arctan2(np.einsum(\"ij,ij->i\", np.cross(carried, u[1:]), t[1:])",
        "    angle = np.arctan2(np.einsum(\"ij,ij->i\", np.cross(u[1:], carried), t[1:])")],
      [f"{LINKING}::test_straight_twisted_rod_and_a_crossing", f"{PLECTONEME}::test_below_buckling_the_rod_twists_straight"],
      "the twist angle measured the wrong way round (from u_{i+1} to the carried u_i): Lk = Wr - Tw"),
    M("rodcontact-residual-at-clamp", "rodfem/core/bodycontact.py",
      [("            own = rows >= 0          # (a Vec does not ignore the index -1 as a Mat does: the supported rows out)",
        "            own = rows >= -1")],
      [f"{PLECTONEME}::test_link_holds_through_buckling_with_self_contact"],
      "the contact's residual written with the index -1 for a supported node (PETSc's Vec refuses it)"),
    M("moving-ground-frame-rate", "rodfem/core/joints.py",
      [("        r_lam = Gq @ vm + Gp @ (p1 - p0) / h", "        r_lam = Gq @ vm")],
      [f"{PLECTONEME}::test_below_buckling_the_rod_twists_straight"],
      "the turning frame's rate left out of the joint's rows: the end does not turn"),
    M("moving-ground-work", "rodfem/core/joints.py",
      [("        return r_v, r_lam, drv_dq, Gq.T, drl_dq, 0.5 * Gq, float(lam @ (Gp @ (p1 - p0)))",
        "        return r_v, r_lam, drv_dq, Gq.T, drl_dq, 0.5 * Gq, 0.0")],
      [f"{PLECTONEME}::test_below_buckling_the_rod_twists_straight"],
      "the moving frame's work not booked in `supplied`: the balance breaks"),

    # -- friction between rods; the contact pattern grown at once (issue 24) ----------------------
    M("rodfriction-one-sided", "rodfem/core/bodycontact.py",
      [("        F = share[:, :, None] * f[:, None, :]", "        F = np.abs(share)[:, :, None] * f[:, None, :]")],
      [f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "the friction force on both rods in the same direction (no reaction): momentum not conserved"),
    M("rodfriction-not-dissipated", "rodfem/core/bodycontact.py",
      [("                lost -= self.h * float(np.sum(power))", "                lost -= 0.0")],
      [f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]",
       f"{ROD_FRICTION}::test_a_rod_sliding_lengthwise_across_two_rods_stops_like_a_block"],
      "the friction's work not booked in `dissipated`: the balance breaks"),
    M("rodfriction-end-velocity", "rodfem/core/bodycontact.py",
      [("        Vm = 0.5 * (V0 + V1)\n", "        Vm = V1\n")],
      [f"{ROD_FRICTION}::test_a_rod_sliding_lengthwise_across_two_rods_stops_like_a_block",
       f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "the slip of the end-of-step velocities instead of the midpoint's: the friction's work is not h f . v_t,m"),
    M("rodfriction-normal-slip", "rodfem/core/bodycontact.py",
      [("        vt = rel - np.einsum(\"nj,nj->n\", rel, n)[:, None] * n", "        vt = rel")],
      [f"{ROD_FRICTION}::test_a_rod_sliding_lengthwise_across_two_rods_stops_like_a_block"],
      "the normal part of the relative velocity left in the slip: the approach is resisted too"),
    M("rodfriction-static-coefficient", "forms/contact.py",
      [("        mu = mu_k + (mu_s - mu_k) * exp(-s2 / v_s ** 2)", "        mu = mu_s + 0.0 * mu_k * exp(-s2 / v_s ** 2)")],
      [f"{ROD_FRICTION}::test_a_rod_sliding_lengthwise_across_two_rods_stops_like_a_block",
       f"{ROD_FRICTION}::test_a_pulled_rod_sticks_below_mu_s_N_and_slides_above[above-threshold]"],
      "the static coefficient while sliding (no Stribeck blend to mu_k)"),
    M("rodfriction-no-velocity-jacobian", "rodfem/core/bodycontact.py",
      [("                         (rows, self._index(p, pairs, (\"v\", \"w\") if framed else (\"v\",)), -dv)]",
        "                         (rows, self._index(p, pairs, (\"v\", \"w\") if framed else (\"v\",)), 0 * dv)]")],
      [f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "Newton's matrix without the friction's derivative in v_{n+1}: Newton stalls on the stiff damper"),
    M("rodcontact-pattern-misses-friction", "rodfem/core/bodycontact.py",
      [("                for kinds in ((\"q\", \"d\"), (\"v\", \"w\")) if rubs else ((\"q\",),):",
        "                for kinds in (((\"q\", \"d\"),)):")],
      [f"{ROD_FRICTION}::test_the_pattern_grown_at_once_gives_the_same_history"],
      "the grown pattern without the friction's (v, v) entries (caught by the count of mallocs)"),
    M("rodfriction-no-couple", "rodfem/core/bodycontact.py",
      [("                beta[:, lo:lo + 2] = self.law.section_coordinates(D, u)[:, None, :]", "                pass")],
      [f"{ROD_FRICTION}::test_a_rod_sliding_across_a_rod_spins_up_until_it_rolls[solid]",
       f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "friction at the centrelines' closest points (no section couple): no spin, angular momentum not kept"),
    M("rodfriction-couple-not-in-slip", "rodfem/core/bodycontact.py",
      [("            Vm = self.law.point_velocity(Vm.reshape(-1, 3)", "            Vm = Vm + 0.0 * self.law.point_velocity(Vm.reshape(-1, 3)")],
      [f"{ROD_FRICTION}::test_a_rod_sliding_across_a_rod_spins_up_until_it_rolls[solid]",
       f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "the couples applied but the slip of the centrelines (no omega x u): the couples' work is not booked, never rolls"),
    M("rodfriction-frame-transposed", "forms/rod_contact.py",
      [("    return np.linalg.solve(np.transpose(D, (0, 2, 1)), u[:, :, None])[:, :, 0]",
        "    return np.einsum(\"mkj,mj->mk\", D, u)")],
      [f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "the arm's coordinates D u (orthonormal frame assumed) instead of solving: the couples miss the forces' moment"),
    M("rodfriction-arms-at-surfaces", "forms/rod_contact.py",
      [("        return ra * d / R, rb * d / R", "        return ra + 0 * d, rb + 0 * d")],
      [f"{ROD_FRICTION}::test_two_free_rods_rubbing_keep_momentum_and_the_balance[discrete-gradient]"],
      "each rod's contact point on its own surface (r_a, r_b): apart by the penetration, the pair's moment is not zero"),
    M("rodcontact-two-tree-reach", "rodfem/core/bodycontact.py",
      [("        reach = float(np.max(radii)) + float(np.max(other_radii))", "        reach = float(np.max(radii))")],
      [f"{ROD_FRICTION}::test_broad_phase_between_two_bodies_finds_every_overlap"],
      "the two bodies' k-d trees searched within max r_a instead of max r_a + max r_b: overlaps missed"),

    # -- a rigid body's sphere against a rod or string (issue 24) -------------------------------------
    M("rigidrod-point-divides-by-zero", "forms/rod_contact.py",
      [("    point_p, point_q = A <= tiny, E <= tiny", "    point_p, point_q = A < 0.0 * tiny, E < 0.0 * tiny")],
      [f"{RIGID_ROD}::test_point_to_segment_distance_against_a_brute_force_search",
       f"{RIGID_ROD}::test_ball_hitting_a_stiff_rod_at_its_centre[equal]"],
      "a segment of zero length through the general formula: 0/0 (NaN) for the sphere's centre"),
    M("rigidrod-point-unclamped", "forms/rod_contact.py",
      [("    a = np.where(point_q, np.where(point_p, 0.0, np.clip(-C / A1, 0.0, 1.0)), a)",
        "    a = np.where(point_q, np.where(point_p, 0.0, -C / A1), a)")],
      [f"{RIGID_ROD}::test_point_to_segment_distance_against_a_brute_force_search"],
      "the sphere centre's projection onto the segment's line left unclamped (beyond the segment)"),
    M("rigidrod-local-indices", "rodfem/core/bodycontact.py",
      [("            found.append(l2g[dofs] if len(dofs) and np.all(dofs < own) else np.zeros(0, np.int64))",
        "            found.append(dofs if len(dofs) and np.all(dofs < own) else np.zeros(0, np.int64))")],
      [f"{RIGID_ROD}::test_ball_hitting_a_stiff_rod_at_its_centre[equal]"],
      "the rigid body's position dofs by their local index, not the global one (another body's rows)"),
    M("rigidrod-zone-weight-of-the-point", "rodfem/core/bodycontact.py",
      [('        wb = 1.0 if not self.self_contact and getattr(self.b, "point", False) else np.minimum(1.0, lb / zone)',
        "        wb = np.minimum(1.0, lb / zone)")],
      [f"{RIGID_ROD}::test_a_sphere_counts_as_one_point_in_the_contact_zone_weights"],
      "the sphere's centre weighted by its zero length over the zone: no contact with a zone"),
    M("rigidrod-frame-of-the-ball", "rodfem/core/bodycontact.py",
      [("        self.d = self.w = None   # no section frame (whatever `frame` says): friction at the centre, no couple\n", "")],
      [f"{RIGID_ROD}::test_a_spinning_ball_rubbing_a_rod_keeps_p_and_the_balance_and_L_changes_by_the_ball_arm"],
      "a rigid body's sphere without its (empty) section frame: friction with a RigidBody ball fails"),
    M("rigidrod-radius-zero-allowed", "rodfem/core/system.py",
      [("            if not radius > 0:", "            if radius < 0:")],
      [f"{RIGID_ROD}::test_bad_input_is_refused_in_one_line"],
      "a sphere of radius 0 accepted"),
    M("rigidrod-radius-other-side", "rodfem/core/system.py",
      [("            radius = law.radii[k]", "            radius = law.radii[1 - k]")],
      [f"{RIGID_ROD}::test_bad_input_is_refused_in_one_line"],
      "the sphere's radius checked on the rod's side"),

    # -- the capstan and the grasp (issue 24) --------------------------------------------------------
    M("capstan-friction-normal-unscaled", "forms/contact.py",
      [("        N = -z * norm\n", "        N = -z\n")],
      [f"{CAPSTAN}::test_sliding_string_has_the_capstan_ratio[pi-0.3]"],
      "the friction's normal force -psi'(xi) without |grad xi| (right on a plane, |grad xi| = 1; wrong on a drum)"),
    M("capstan-arc-spacing", "demos/capstan.py",
      [('    h = 2 * Rc * np.sin(theta / (2 * n_a)) / stretch(p, p["T1"])', '    h = Rc * theta / n_a / stretch(p, p["T1"])')],
      [f"{CAPSTAN}::test_sliding_string_has_the_capstan_ratio[pi-0.3]"],
      "the string's nodes on the drum at arc-length spacing: its chords start compressed, not at T1"),
    M("capstan-oracle-sign", "demos/capstan.py",
      [("        ratio *= (e_in @ t + mu * (e_in @ n)) / (e_out @ t + mu * (e_out @ n))",
        "        ratio *= (e_in @ t - mu * (e_in @ n)) / (e_out @ t - mu * (e_out @ n))")],
      [f"{CAPSTAN}::test_sliding_string_has_the_capstan_ratio[pi-0.3]"],
      "the discrete polygon's node balance with the friction turned round"),
    M("capstan-regularization-ignored", "demos/capstan.py",
      [('    mu = p["mu"] * p["V"] / np.hypot(p["V"], p["eps"])\n    return', '    mu = p["mu"]\n    return')],
      [f"{CAPSTAN}::test_regularized_friction_gives_the_regularized_ratio"],
      "the regularized ratio with the Coulomb coefficient (the viscous part below eps ignored)"),
    M("capstan-push", "demos/capstan.py",
      [("        return -u * direction", "        return u * direction")],
      [f"{CAPSTAN}::test_sliding_string_has_the_capstan_ratio[pi-0.3]"],
      "the right end pushed instead of pulled"),
    M("grasp-soft-penalty", "demos/soft_arm_grasp.py",
      [('stiffness_for(tau / Rw, p["penetration"])', 'stiffness_for(tau / Rw, 4 * p["penetration"])')],
      [f"{GRASP}::test_grasp_keeps_the_balance_and_the_penetration"],
      "the pole's penalty made for four times the stated penetration"),

    # -- 3D rod materials (issue 31) --
    M("rod-material-dg-dropped", "forms/cosserat_rod.py",
      [('weights=[c[f"w{i}"] for i in range(6)])', 'weights=[0.0 * c[f"w{i}"] for i in range(6)])')],
      ["tests/models/test_rod_materials.py::test_balance_is_exact_with_the_discrete_gradient[stiffening]",
       "tests/models/test_rod_materials.py::test_balance_is_exact_with_the_discrete_gradient[asymmetric]"],
      "the discrete gradient's correction dropped for W*(N, M): the midpoint effort dW*(x_m)"),
    M("rod-material-stored-energy-is-W*", "forms/cosserat_rod.py",
      [('pot = (ufl.inner(x["N"], x["gamma"]) + ufl.inner(x["M"], x["kappa"])\n                   - self._complementary(x["N"], x["M"]))',
        'pot = self._complementary(x["N"], x["M"])')],
      ["tests/models/test_rod_materials.py::test_balance_is_exact_with_the_discrete_gradient[stiffening]",
       "tests/models/test_rod_materials.py::test_balance_is_exact_with_the_discrete_gradient[asymmetric]"],
      "the complementary energy W* booked as the stored energy (no Legendre transform N.gamma - W*)"),
    M("rod-material-coupling-sign", "forms/rod_materials.py",
      [("+ C_NM * N[0] * M[0]", "- C_NM * N[0] * M[0]")],
      ["tests/models/test_rod_materials.py::test_stretch_twist_against_its_two_by_two_solve"],
      "the stretch-twist coupling with the wrong sign (still positive definite, still energy-consistent)"),
    M("rod-material-lock-scale", "forms/rod_materials.py",
      [("1.0 + ufl.sqrt(1.0 + c * q / kappa_lock ** 2)", "1.0 + ufl.sqrt(1.0 + c * q / kappa_lock)")],
      ["tests/models/test_rod_materials.py::test_stiffening_roll_up_closes_the_circle"],
      "the stiffening law's locking curvature entering unsquared (the scene's moment follows the wrong law)"),
    M("rod-material-asymmetry-swapped", "forms/rod_materials.py",
      [("0.5 * C_N1c * N[0] ** 2 + (C_N1 - C_N1c) * ramp_energy", "0.5 * C_N1 * N[0] ** 2 + (C_N1c - C_N1) * ramp_energy")],
      ["tests/models/test_rod_materials.py::test_asymmetric_axial_law_in_tension_and_compression[tension]",
       "tests/models/test_rod_materials.py::test_asymmetric_axial_law_in_tension_and_compression[compression]"],
      "tension and compression compliances swapped in the asymmetric axial law"),
    M("rod-material-weights-ignore-constraints", "forms/rod_materials.py",
      [("return [0.0 if gi == 0.0 else 1.0 / S ** 2 for S, gi in zip(self.scales(), g)]",
        "return [1.0 / S ** 2 for S, gi in zip(self.scales(), g)]")],
      ["tests/models/test_rod_materials.py::test_zero_compliances_with_a_nonquadratic_law"],
      "the discrete gradient's correction also on zero-compliance components: constrained strains drift"),
    M("rod-material-linear-generic", "forms/cosserat_rod.py",
      [('elif type(material).__name__ == "linear":', "elif False:")],
      ["tests/models/test_rod_materials.py::test_linear_material_is_the_compliance_form_bit_for_bit"],
      "the linear material through the generic quadratic rows: other compiled forms than before"),

    # -- adaptive steps (issue 25) ----------------------------------------------------------------------
    M("substeps-from-the-failed-state", "rodfem/analysis/timeloop.py",
      [("                if snap is not None:\n                    problem.restore(snap)\n", "")],
      [STEPPING + "::test_a_sub_step_that_fails_partway_through_a_split_restarts_from_x_n"],
      "a split whose sub-step fails partway is retried in more sub-steps from the failed state, not from x_n"),
    M("adaptive-snapshot-of-a-stale-state", "rodfem/core/system.py",
      [('        self._pull(self.X0, "x0")\n        return (self.X0.getArray(readonly=True).copy(),',
        '        return (self.X0.getArray(readonly=True).copy(),')],
      [ADAPTIVE + "::test_adaptive_meets_a_fixed_step_reference_on_systems[crane-manoeuvre]"],
      "a rejected adaptive step restores the state the system was built with (before a scene's static equilibrium)"),
    M("adaptive-constrained-velocities-unscaled", "rodfem/analysis/stepping.py",
      [("        diff[scaled] *= h\n", "")],
      [ADAPTIVE + "::test_adaptive_meets_a_fixed_step_reference_on_systems[four-bar-2d]"],
      "the joints' (-1)^n velocity mode measured as an error: the mechanism's steps collapse"),
    M("adaptive-multipliers-in-the-norm", "rodfem/core/system.py",
      [("            algebraic = set(body.algebraic_fields())\n", "            algebraic = set()\n")],
      [ADAPTIVE + "::test_the_error_norm_leaves_out_multipliers_and_scales_the_constrained_velocities"],
      "the bodies' own multipliers (a rigid body's orthonormality) measured as states"),
    M("servo-start-observed-a-step-later", "rodfem/core/servo.py",
      [("    points.x0_values, points.times = before\n", "")],
      ["tests/models/test_servo.py::test_newton_options_before_the_first_run_keep_the_start_residual"],
      "x_0's constraint residual read against the path at the end of a step of the build-time h"),
    M("auto-first-step-ignores-the-frames", "rodfem/analysis/stepping.py",
      [("    return min(later[0] - t, 0.1 * (t_end - t))\n", "    return 0.1 * (t_end - t)\n")],
      [ADAPTIVE + "::test_dt_auto_starts_from_the_scene_time_scale"],
      "dt=auto: the first step t_end/10 whatever the frames"),
    M("substep-work-of-the-last-only", "rodfem/analysis/timeloop.py",
      [("its, work, lost = its + s_its, work + w, lost + d", "its, work, lost = its + s_its, w, d")],
      [STEPPING + "::test_the_robot_arm_at_the_authors_step_completes_in_sub_steps"],
      "a step done in sub-steps supplies only its last sub-step's work h y.u"),
    M("inputs-at-the-step-start", "rodfem/analysis/timeloop.py",
      [("    problem.set_time(t + 0.5 * h)\n", "    problem.set_time(t)\n")],
      [STEPPING + "::test_the_robot_arm_at_the_authors_step_completes_in_sub_steps",
       STEPPING + "::test_adaptive_steps_meet_the_tolerance_of_an_exact_solution"],
      "every (sub-)step reads its inputs at its start, not at its midpoint"),
    M("adaptive-accepts-every-step", "rodfem/analysis/timeloop.py",
      [("        if err > 1.0:\n", "        if err > 1e300:\n")],
      [STEPPING + "::test_adaptive_steps_meet_the_tolerance_of_an_exact_solution"],
      "the error estimate is computed but never rejects a step"),
    M("adaptive-error-per-step-misscaled", "rodfem/analysis/stepping.py",
      [("e = diff / (2 ** ORDER - 1) /", "e = diff / (2 ** ORDER + 7) /")],
      [STEPPING + "::test_adaptive_steps_meet_the_tolerance_of_an_exact_solution"],
      "the Richardson estimate divided by 2^p + 7 instead of 2^p - 1: the error underestimated 3.7 times"),
    M("adaptive-misses-the-output-times", "rodfem/analysis/timeloop.py",
      [("        clipped = t + 1.1 * proposed >= target\n", "        clipped = t + proposed >= t_end\n")],
      [STEPPING + "::test_adaptive_steps_meet_the_tolerance_of_an_exact_solution"],
      "adaptive steps step over the output times (the frames' times are not hit)"),
    M("checkpoint-without-the-step-control", "rodfem/io/checkpoint.py",
      [('                           stepping=meta.get("stepping") or None)', "                           stepping=None)")],
      [STEPPING + "::test_a_resumed_adaptive_run_equals_the_uninterrupted_one"],
      "a resumed adaptive run starts its step control afresh (first step dt, no predictor ratio, counts at 0)"),
    M("no-line-search", "rodfem/nls/newton.py",
      [('DEFAULTS = {"snes_type": "newtonls", "snes_linesearch_type": "bt",',
        'DEFAULTS = {"snes_type": "newtonls", "snes_linesearch_type": "basic",')],
      [STEPPING + "::test_the_line_search_carries_the_robot_arm_at_dt_01"],
      "Newton's full steps again: the robot arm at h = 0.1 needs sub-steps"),
    M("no-minimum-step", "rodfem/analysis/timeloop.py",
      [("                    if dt / (2 * k) < h_min * (1 - 1e-12):\n", "                    if k > 2 ** 40:\n")],
      [STEPPING + "::test_below_the_smallest_step_the_run_ends_with_exit_3_in_one_line"],
      "a failing step is split without the stated minimum dt_min"),
    # -- DOLFINx versions (rodfem/fem/compat.py, issue 28) ----------------------------------------------
    M("compat-adjacency-transposed", "rodfem/fem/compat.py",
      [("return np.asarray(adj.array).reshape(-1, n) if n", "return np.asarray(adj.array).reshape(n, -1).T if n")],
      ["tests/fem/test_assembly.py::test_fast_assembly_is_dolfinx_assembly",
       "tests/fem/test_assembly.py::test_linear_time_collapse_is_dolfinx_collapse"],
      "0.5's cell-to-dof and cell-to-node lists read column by column: each cell gets other cells' dofs"),
    M("compat-expression-cells-ignored", "rodfem/fem/compat.py",
      [("    return expr.eval(cells)\n", "    return expr.eval(np.zeros_like(cells))\n"),
       ("    first = next(iter(inspect.signature(expr.eval).parameters))\n",
        "    import numpy as np\n    first = next(iter(inspect.signature(expr.eval).parameters))\n")],
      ["tests/io/test_output.py::test_planar_beam_polyline_surface_strains_and_frames",
       "tests/io/test_output.py::test_helix_strains_moments_surface_and_no_velocities"],
      "the output expressions evaluated on the first cell for every cell (0.5 branch of eval_expression)"),
    # -- thermoelastic string (issue 30) --
    M("conduction-without-the-product-rule", "forms/thermoelastic_string.py",
      [("- deta * theta.dx(0) / theta ** 2)\n", "- 0.0 * deta * theta.dx(0) / theta ** 2)\n")],
      [THERMO + "::test_total_energy_exact_and_entropy_production_nonnegative",
       THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "the conduction term kappa theta' (deta/theta)' written as kappa theta' deta'/theta: the energy test "
      "theta no longer cancels it (conduction creates or destroys energy)"),
    M("thermal-coupling-sign", "forms/thermoelastic_string.py",
      [('zC = zW + 0.5 * k["beta"] * k["theta0"] - 0.5 * k["beta"] / k["c"] * dT',
        'zC = zW + 0.5 * k["beta"] * k["theta0"] + 0.5 * k["beta"] / k["c"] * dT')],
      [THERMO + "::test_heated_bar_free_expansion_closed_form[kirchhoff]",
       THERMO + "::test_total_energy_exact_and_entropy_production_nonnegative"],
      "the thermal stress with the wrong sign in the step's efforts: the heated free bar is not stress-free "
      "at L sqrt(1 + 2 alpha dtheta), and the rows no longer match the energy H"),
    M("energy-coupling-sign", "forms/thermoelastic_string.py",
      [('return (self.W(C, domain) + k["beta"] * k["theta0"] * m', 'return (self.W(C, domain) - k["beta"] * k["theta0"] * m')],
      [THERMO + "::test_total_energy_exact_and_entropy_production_nonnegative"],
      "H's coupling term with the wrong sign: H is no longer the energy whose discrete gradient the rows use"),
    M("heat-flux-entropy-at-the-old-temperature", "forms/heat_ports.py",
      [('return -(self.constant * test["eta"] / step.x1["theta"] + _metered',
        'return -(self.constant * test["eta"] / step.x0["theta"] + _metered')],
      [THERMO + "::test_heat_flux_port_energy_and_mean_temperature"],
      "the flux port's entropy flow Q/theta with theta of t_n: the heat that enters is not the booked Q"),
    M("convection-power-at-the-old-temperature", "forms/heat_ports.py",
      [('        return self._flow(step.x1["theta"]) * dx', '        return self._flow(step.x0["theta"]) * dx')],
      [THERMO + "::test_convection_exact_recurrence[discrete-gradient]"],
      "the convection's booked power uses theta of t_n, not the step's temperature: the balance is off"),
    M("dashpot-heat-dropped", "forms/thermoelastic_string.py",
      [("            S, heat = S + 2 * Wk, heat + R * Wk ** 2", "            S, heat = S + 2 * Wk, heat + 0.0 * R * Wk ** 2")],
      [THERMO + "::test_maxwell_dashpot_work_becomes_heat"],
      "the Maxwell dashpots' work is not turned into heat: the total energy of a viscoelastic thermoelastic string decays"),
    M("viscous-heat-dropped", "forms/thermoelastic_string.py",
      [("            S, heat = S + Sv, heat + Sv * Edot", "            S, heat = S + Sv, heat")],
      [THERMO + "::test_viscous_damping_work_becomes_heat[kelvin-voigt]"],
      "the Kelvin-Voigt damping's work is not turned into heat: the total energy decays"),
    M("thermal-dg-is-midpoint", "forms/thermoelastic_string.py",
      [('    if rule == "discrete-gradient":\n', '    if False:\n')],
      [THERMO + "::test_total_energy_exact_and_entropy_production_nonnegative",
       THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "the thermal quotient T'_bar without its sinh(y)/y factor (the midpoint derivative): e(C, eta) is "
      "exponential in eta, the energy is no longer exact"),
    # -- thermoelastic planar beam and the heat meter (issue 30) --
    M("beam-thermal-force-sign", "forms/thermoelastic_beam.py",
      [('return N + (k["beta"] * k["theta0"] - k["beta"] / k["c"] * dT) * E1, M',
        'return N + (k["beta"] * k["theta0"] + k["beta"] / k["c"] * dT) * E1, M')],
      [THERMO_BEAM + "::test_free_thermal_expansion[hooke]",
       THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "the beam's thermal axial force with the wrong sign in the step's efforts: the heated free beam is not "
      "stress-free at L (1 + alpha dtheta), and the rows no longer match H"),
    M("beam-energy-coupling-sign", "forms/thermoelastic_beam.py",
      [('return (self.energy(Gamma, kappa) + k["beta"] * k["theta0"] * Gamma[0]',
        'return (self.energy(Gamma, kappa) - k["beta"] * k["theta0"] * Gamma[0]')],
      [THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "H's coupling term of the beam with the wrong sign: H is not the energy of the rows' discrete gradient"),
    M("beam-efforts-not-projected", "forms/thermoelastic_beam.py",
      [("    projects = True\n", "    projects = False\n")],
      [THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "the beam's thermal resultant (varying inside a cell with eta) used unprojected at degree 1: the strain "
      "rows' bracket is then not the strain increment, the energy is not exact"),
    M("beam-temperature-row-not-the-quotient", "forms/thermoelastic_beam.py",
      [("thermal = ((theta - self.entropy_effort(step, dom)) * dth",
        'thermal = ((theta - self.temperature(step.x1["Gamma"], step.x1["eta"], dom)) * dth')],
      [THERMO_BEAM + "::test_total_energy_exact_and_entropy_production_nonnegative[1]"],
      "the step's temperature the temperature of x_{n+1} instead of the discrete gradient z_eta: not exact"),
    M("beam-dashpot-heat-dropped", "forms/thermoelastic_beam.py",
      [("            thermal -= heat * deta / theta * dx\n", "            thermal -= 0.0 * heat * deta / theta * dx\n")],
      [THERMO_BEAM + "::test_dashpot_work_becomes_heat[maxwell]",
       THERMO_BEAM + "::test_dashpot_work_becomes_heat[kelvin-voigt]"],
      "the beam's dashpot and viscous work is not turned into heat: its total energy decays"),
    M("heat-meter-misses-convection", "forms/heat_ports.py",
      [("_metered(test, self._flow(theta))", "_metered(test, 0.0 * self._flow(theta))")],
      ["tests/models/test_heat_supplied.py::test_heat_supplied_apart_from_mechanical_work"],
      "heat_supplied leaves out the convection's heat"),
    M("heat-meter-flux-halved", "forms/heat_ports.py",
      [("_metered(test, self.constant)", "_metered(test, 0.5 * self.constant)")],
      ["tests/models/test_heat_supplied.py::test_constant_flux_heat_supplied_is_q_t"],
      "heat_supplied books half the flux port's heat"),
    # -- the step interface and the reduced models (issue 29) --------------------------------------
    M("simulator-restore-keeps-the-history", "rodfem/app/simulator.py",
      [("        del self.history.rows[state.rows:]\n", "")],
      [SIMULATOR + "::test_save_restore_and_reset_replay_exactly"],
      "restore() rolls the state back but the history keeps the rows of the undone steps"),
    M("simulator-restore-forgets-the-predictor", "rodfem/app/simulator.py",
      [("        self._previous = None if state.previous is None else state.previous.copy()\n",
        "        self._previous = None\n")],
      [SIMULATOR + "::test_save_restore_and_reset_replay_exactly"],
      "a restored simulator starts Newton from another guess: a replay is not the same run"),
    M("simulator-split-outputs-summed", "rodfem/app/simulator.py",
      [("                                     for j in range(p.size)]) / k\n", "                                     for j in range(p.size)])\n")],
      [SIMULATOR + "::test_a_step_newton_cannot_take_is_split_as_in_the_time_loop"],
      "a step done in sub-steps returns the sum of their outputs: h u.y is no longer the step's work"),
    M("reduce-galerkin-instead-of-effort-constraint", "rodfem/analysis/reduce.py",
      [("    W = np.asarray(full.Q @ V)\n", "    W = V\n")],
      [REDUCE + "::test_reduced_model_is_port_hamiltonian_and_passive",
       REDUCE + "::test_transfer_functions_agree_at_the_interpolation_points"],
      "a Galerkin projection W = V: Q_r = I is no longer the reduced model's energy, C_r != B_r^T"),
    M("reduce-dissipation-sign", "rodfem/analysis/reduce.py",
      [("    Jr, Rr, Esym = 0.5 * (M - M.T), 0.5 * (N + N.T), 0.5 * (Er + Er.T)\n",
        "    Jr, Rr, Esym = 0.5 * (M - M.T), -0.5 * (N + N.T), 0.5 * (Er + Er.T)\n")],
      [REDUCE + "::test_reduced_model_is_port_hamiltonian_and_passive"],
      "the reduced dissipation with the wrong sign (an active reduced model)"),
    M("reduce-one-direction-per-frequency", "rodfem/analysis/reduce.py",
      [("        b = Vh[k % Vh.shape[0]].conj()\n", "        b = Vh[0].conj()\n")],
      [REDUCE + "::test_transfer_functions_agree_at_the_interpolation_points"],
      "a repeated frequency gets the same direction twice (the hanging cable's second pendulum plane is lost)"),
    M("galerkin-effort-basis-not-the-strain-basis", "rodfem/analysis/galerkin.py",
      [("    V[lay.n, 2 * rq + re:] = Psi\n", "    V[lay.n, 2 * rq + re:] = Psi[::-1]\n")],
      [GALERKIN + "::test_reduced_energy_balance_is_exact"],
      "the effort fields reduced with another basis than the strains: the projected effort is no longer a "
      "test vector of the strain rows, the reduced energy balance breaks"),
    M("galerkin-no-strain-images", "rodfem/analysis/galerkin.py",
      [("    if problem is not None:   # the strain images first", "    if False:   # the strain images first")],
      [GALERKIN + "::test_no_configuration_mode_without_stiffness"],
      "the energy basis without the configuration modes' strain images: stiffness-free modes"),
    M("galerkin-one-newton-iteration", "rodfem/analysis/galerkin.py",
      [("            if norm <= ATOL or norm <= RTOL * r0 or small:", "            if it >= 1 or norm <= ATOL or small:")],
      [GALERKIN + "::test_reduced_energy_balance_is_exact"],
      "the reduced Newton stops after one iteration: the Galerkin residual is not zero, nor the balance exact"),
    M("galerkin-accept-keeps-the-old-state", "rodfem/analysis/galerkin.py",
      [("        self.xi0 = self.xi1.copy()\n        self._push_x0()\n        return previous",
        "        self.xi0 = self.xi1.copy()\n        return previous")],
      [GALERKIN + "::test_full_rank_reproduces_the_full_model"],
      "accept() does not put x_{n+1} into the problem's x_n: every step starts from the initial state"),
    # -- ECSW hyper-reduction (issue 29) --
    M("ecsw-energy-not-weighted", "rodfem/fem/sampled.py",
      [("    if (rank == 0) { o[0] += we * Ae[0]; continue; }", "    if (rank == 0) { o[0] += Ae[0]; continue; }")],
      [ECSW + "::test_weighted_energy_balance_is_exact"],
      "H summed over the sampled cells without their weights: not the Hamiltonian of the weighted model, whose "
      "energy balance then breaks"),
    M("ecsw-weights-dropped", "rodfem/fem/sampled.py",
      [("    double we = w[e];", "    double we = 1.0;")],
      [ECSW + "::test_error_stays_close_to_the_galerkin_model"],
      "every sampled cell with weight 1 (the weights dropped): a consistent but wrong model, a third of the beam"),
    M("ecsw-jacobian-not-weighted", "rodfem/fem/sampled.py",
      [("        double v = we * Vr[a];\n        if (v == 0.0) continue;",
        "        double v = Vr[a];\n        if (v == 0.0) continue;")],
      [ECSW + "::test_sampled_jacobian_is_the_derivative_of_the_sampled_residual"],
      "the reduced Jacobian without the weights: not the derivative of the weighted residual"),
    M("ecsw-negative-weights", "rodfem/analysis/ecsw.py",
      [("            if np.all(z > 0):\n", "            if True:\n")],
      [ECSW + "::test_nnls_reaches_the_constrained_optimum_of_scipy",
       ECSW + "::test_weights_are_positive_few_and_fit_within_the_tolerance"],
      "the active set's least squares without the sign constraint: negative weights (an H_w that can be negative)"),
    M("ecsw-point-load-weighted", "rodfem/fem/sampled.py",
      [("                keep = np.ones(len(ent_cells), bool)\n                w = np.ones(int(keep.sum()))\n",
        "                keep = np.array([c in by_cell for c in ent_cells.tolist()], bool)\n"
        "                w = np.array([by_cell.get(c, 0.0) for c in ent_cells[keep].tolist()])\n")],
      [ECSW + "::test_point_load_is_not_weighted"],
      "the tip load (a facet term) weighted like a cell integral: dropped when its cell is not sampled"),
    M("galerkin-damped-basis-not-split", "rodfem/analysis/galerkin.py",
      [("    if lay.damped:   # the energy basis component by component", "    if False:   # the energy basis component by component")],
      [ECSW + "::test_damped_scene_keeps_its_balance_with_dissipation"],
      "with Kelvin-Voigt damping the energy basis not split by strain component: the viscous stress D e_n is not a "
      "test vector of the reduced strain rows, the balance with dissipation breaks"),
    M("ecsw-vanishing-equations-fitted", "rodfem/analysis/ecsw.py",
      [("        keep = scale > VANISHING * scale.max(initial=0.0)\n", "        keep = scale > 0.0\n")],
      [ECSW + "::test_weights_are_positive_few_and_fit_within_the_tolerance"],
      "the identically vanishing kinematic equations kept in the training: their round-off, scaled up, is fitted "
      "as noise and the sample grows to most of the mesh"),
    # -- Kelvin-Voigt and Rayleigh damping (issue 25) --
    M("kv-pointwise-strain-rate", "forms/planar_beam.py",
      [('        Gdot, kdot = step.rate("Gamma"), step.rate("kappa")\n',
        '        A, r_s, v, w = rotation(step.mid("phi")), step.mid("r").dx(0), step.mid("v"), step.mid("omega")\n'
        '        Gdot, kdot = A.T * (v.dx(0) - w * S_HAT * r_s), w.dx(0)\n')],
      [DAMPING + "::test_free_decay_planar_cantilever[kv]"],
      "the planar dashpots see the pointwise strain rate, not its projection: energy-consistent, but the P1 "
      "element's shear part locks and over-damps bending"),
    M("kv-dissipation-not-booked", "forms/planar_beam.py",
      [("            d = d + ufl.inner(Nv, Gdot) + Mv * kdot\n", "")],
      [DAMPING + "::test_exact_balance_with_damping[planar-kv-alpha-midpoint]"],
      "the viscous stresses act, their dissipation is not booked in `dissipated`"),
    M("rayleigh-alpha-force-missing", "forms/planar_beam.py",
      [("            F += mass_damping\n", "            pass\n")],
      [DAMPING + "::test_exact_balance_with_damping[planar-kv-alpha-midpoint]",
       DAMPING + "::test_rigid_rotation_dissipates_nothing[planar]"],
      "Rayleigh's -alpha rho v is booked as dissipated but never applied"),
    M("rod-kv-moments-reversed", "forms/cosserat_rod.py",
      [("[eN[i] for i in range(3)] + [eM[i] for i in range(3)])", "[eN[i] for i in range(3)] + [eM[2 - i] for i in range(3)])")],
      [DAMPING + "::test_free_decay_rod_cantilever[kv]"],
      "the 3D rod's torsion and bending viscosities swapped (balanced, a wrong damping ratio)"),
    M("rod-kv-not-objective", "forms/cosserat_rod.py",
      [("        eN, eM = self._strain_rates(step, domain)\n",
        "        eN, eM = step.mid(\"v\").dx(0), self._strain_rates(step, domain)[1]\n")],
      [DAMPING + "::test_rigid_rotation_dissipates_nothing[rod]"],
      "the 3D rod's axial dashpot damps d_s v, which a rigid rotation has too (not objective)"),
    M("string-alpha-end-mass-missing", "forms/string.py",
      [("            ends_v = self._lumped(ds, alpha * ufl.inner(v, dv))\n", "            ends_v = None\n")],
      [DAMPING + "::test_exact_balance_with_damping[string-kv-alpha-discrete-gradient]"],
      "Rayleigh's mass part forgets the string's end masses (booked, not applied)"),
    M("kv-negative-viscosity-accepted", "forms/damping.py",
      [("        if not np.all(np.isfinite(eta)) or np.any(eta < 0):", "        if not np.all(np.isfinite(eta)):")],
      [DAMPING + "::test_bad_values_are_one_line_parameter_errors"],
      "a negative viscosity (an energy source) is accepted from the Python API"),
    M("scene-ignores-tau-kv", "demos/_planar.py",
      [('degree=p["degree"], damping=kv)', 'degree=p["degree"])')],
      [DAMPING + "::test_free_decay_planar_cantilever[kv]"],
      "cantilever-2d accepts --set tau_kv but builds the undamped beam"),
    # -- output (issue 27): what the files show is the model's state ------------------------------
    M("output-configuration-strain", "forms/cosserat_rod.py",
      [('strains = {"strain_from_N": CN, "strain_from_M": CM}',
        'strains = {"strain_from_N": shear_strain(x["r"], [x[n] for n in DIRECTORS]) - ufl.as_vector([1.0, 0.0, 0.0]), '
        '"strain_from_M": CM}')],
      ["tests/io/test_output_physics.py::test_3d_rod_strains_are_the_stress_resultants_strains"],
      "the 3D rod exports the configuration's Gamma(q) again (zig-zag between nodes), not C_N N"),
    M("output-frames-snap-to-levels", "rodfem/io/output.py",
      [("return [(j * n_steps // k, (j * n_steps % k) / k) for j in range(k + 1)]",
        "return [((2 * j * n_steps + k) // (2 * k), 0.0) for j in range(k + 1)]")],
      ["tests/io/test_output_physics.py::test_frames_on_the_requested_times_interpolated_between_levels"],
      "frames at the nearest time level, not at the requested times"),
    M("output-blend-weights-swapped", "rodfem/io/snapshot.py",
      [("lambda x, y: None if x is None else (1 - theta) * x + theta * y",
        "lambda x, y: None if x is None else theta * x + (1 - theta) * y")],
      ["tests/io/test_output_physics.py::test_frames_on_the_requested_times_interpolated_between_levels"],
      "a frame between two levels takes the weights of the wrong ends"),
    M("output-time-not-clean", "rodfem/io/output.py",
      [('    return float(f"{t:.12g}")', "    return float(t)")],
      ["tests/io/test_output_physics.py::test_frames_on_the_requested_times_interpolated_between_levels"],
      "frame times with the step sum's round-off (0.30000000000000004)"),
    M("output-normals-d3", "rodfem/io/frames.py",
      [('return {"Normals": "d2", "Vectors": velocity', 'return {"Normals": "d3", "Vectors": velocity')],
      ["tests/io/test_output_physics.py::test_active_attributes_and_units_of_every_file"],
      "the active Normals are d3: a 4-sided Tube turns a quarter off the section"),
    M("output-unit-of-curvature", "forms/cosserat_rod.py",
      [('"strain_from_M": "1/m"', '"strain_from_M": "1"')],
      ["tests/io/test_output_physics.py::test_active_attributes_and_units_of_every_file"],
      "the curvature's unit written as dimensionless"),
    M("output-section-axes-swapped", "rodfem/io/sections.py",
      [("return np.column_stack([r * np.cos(a), r * np.sin(a)])", "return np.column_stack([r * np.sin(a), r * np.cos(a)])")],
      ["tests/io/test_output_physics.py::test_round_section_of_the_scene_turns_with_the_directors"],
      "the round section's marker fin along d3, not d2 (twist drawn a quarter turn off)"),
    M("output-joint-offset-ignored", "rodfem/io/glyphs.py",
      [("if frame is not None and any(offset) else", "if frame is not None and False else")],
      ["tests/io/test_output_physics.py::test_joints_block_puts_each_joint_where_its_bodies_are"],
      "a rigid body's joint drawn at its centre, not at the joint's offset"),
    M("output-view-ranges-first-frame", "rodfem/io/paraview.py",
      [('for _, _, f, _ in read_pvd(os.path.join(out, "surface.pvd")):',
        'for _, _, f, _ in read_pvd(os.path.join(out, "surface.pvd"))[:1]:')],
      ["tests/io/test_output_physics.py::test_view_script_facts_are_those_of_the_files"],
      "view.py's colour ranges read back from the first frame only (a resumed run's view.py)"),
    M("output-view-ranges-last-frame", "rodfem/io/paraview.py",
      [("(where, min(o[1], float(v[:, k].min())), max(o[2], float(v[:, k].max())))",
        "(where, float(v[:, k].min()), float(v[:, k].max()))")],
      ["tests/io/test_output_physics.py::test_view_script_has_the_ranges_of_all_frames"],
      "view.py's colour ranges those of the last frame written, not of all frames"),
    # -- tendon-arm-dynamic: the soromox tendon benchmark (issue 25) ------------------------------------
    M("tendon-arm-dynamic-shear-modulus", "demos/tendon_arm_dynamic.py",
      [('E, G = p["E"], p["E"] / (2 * (1 + p["nu"]))', 'E, G = p["E"], p["E"] / (2 * p["nu"])')],
      [f"{TENDON_DYN}::test_tau_kv_is_soromox_eta_over_G"],
      "G = E/(2 nu) instead of E/(2 (1 + nu)): tau_kv = eta/G no longer soromox's D"),
    M("tendon-arm-dynamic-no-damping", "demos/tendon_arm_dynamic.py",
      [("arm = cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, damping=kv)",
        "arm = cosserat_rod.CosseratRod(rhoA, rhoJ, C_N, C_M, damping=None)")],
      [f"{TENDON_DYN}::test_falls_over_with_the_exact_balance", f"{TENDON_DYN}::test_first_mode_damping_ratio"],
      "the scene's Kelvin-Voigt damping not passed to the rod"),
    M("tendon-arm-dynamic-tendons-opposite", "demos/tendon_arm_dynamic.py",
      [('actuators.on_circle(p["offset"], i * np.pi / 2)', 'actuators.on_circle(p["offset"], i * np.pi)')],
      [f"{TENDON_DYN}::test_falls_over_with_the_exact_balance"],
      "the second tendon on -d2 instead of d3 (the two cancel; the arm tips over only by round-off)"),
    M("shooting-guess-ignored", "forms/actuators.py",
      [("G0 = np.zeros(3) if G0 is None else np.array(G0, float)", "G0 = np.zeros(3)")],
      [f"{TENDON_DYN}::test_long_time_limit_is_the_fallen_static_equilibrium"],
      "shooting_statics ignores its starting guess G0: Newton finds the upright equilibrium, not the fallen one"),
    M("tendon-arm-dynamic-guess-moment-sign", "demos/tendon_arm_dynamic.py",
      [("moments = np.cross(near, f)", "moments = np.cross(f, near)")],
      [f"{TENDON_DYN}::test_long_time_limit_is_the_fallen_static_equilibrium"],
      "the base moment of the guess with the wrong sign (Newton starts on the other side)"),
    # -- bodies assembled as a batch (rodfem/fem/batch.py) ------------------------------------------
    M("batch-first-body-constants", "rodfem/fem/fastassembly.py",
      [("    kernel(be, coeffs + (size_t)e * cstride, consts + (size_t)cbody[e] * kstride, coords, facets ? facets + e : NULL, &perm);",
        "    kernel(be, coeffs + (size_t)e * cstride, consts, coords, facets ? facets + e : NULL, &perm);")],
      [BATCH + "::test_chain_batched_equals_body_by_body"],
      "every body of a batch assembled with the first body's constants (its load, its stiffness)"),
    M("batch-stale-coefficients", "rodfem/fem/fastassembly.py",
      [("  for (int k = 0; k < no; ++k) memcpy(S + ooff[k]", "  for (int k = 0; k < 0; ++k) memcpy(S + ooff[k]")],
      [BATCH + "::test_chain_batched_equals_body_by_body"],
      "the batch keeps the coefficients other than the iterate (x_n) as they were at build"),
    M("batch-stale-constants", "rodfem/fem/fastassembly.py",
      [("  for (int k = 0; k < nc; ++k) memcpy(consts + coff[k]", "  for (int k = 0; k < 0; ++k) memcpy(consts + coff[k]")],
      [BATCH + "::test_bodies_of_different_sizes_share_a_batch"],
      "the batch keeps the constants (h, the loads' values) as they were at build"),
    M("batch-no-lifting", "rodfem/fem/batch.py",
      [("            if np.any(gap != 0.0):", "            if False:")],
      [BATCH + "::test_residual_at_a_state_off_the_supports"],
      "the batch's residual leaves out the lifting of a support the iterate does not meet"),
    M("batch-no-dirichlet-diagonal", "rodfem/fem/batch.py",
      [("            if ng >= 0 and len(self.bc_diag):", "            if False:")],
      [BATCH + "::test_chain_batched_equals_body_by_body"],
      "the batch's Jacobian has no 1 on the diagonal of its supported rows"),
    # -- small steps (issue 26): views made once, the doomed LU skipped ----------------------------
    M("scalar-job-sums-not-zeroed", "rodfem/fem/fastassembly.py",
      [("    for (int b = 0; b < nb; ++b) s[b] = 0.0;\n", "")],
      [BATCH + "::test_chain_batched_equals_body_by_body"],
      "a functional's per-integral sums not zeroed: H, the work and the columns accumulate over the calls"),
    M("job-gather-partial", "rodfem/fem/fastassembly.py",
      [("  const int64_t m = n[i] * cstride[i];", "  const int64_t m = n[i] * cstride[i] / 2;")],
      [BATCH + "::test_chain_batched_equals_body_by_body"],
      "the batch's kernels get only the first half of their cells' coefficients gathered (the rest stale)"),
    M("batch-structure-views-kept", "rodfem/fem/batch.py",
      [("        self._views = (ffi.from_buffer", "        self._views = getattr(self, \"_views\", None) or (ffi.from_buffer")],
      ["tests/fem/test_assembly.py::test_fast_assembly_inserts_an_entry_outside_its_pattern"],
      "after the pattern grew the batch's Jacobian keeps its views of the old structure"),
    M("zero-pivot-memory-not-read", "rodfem/nls/newton.py",
      [("        following = _ZERO_PIVOTS.get(self._pattern)", "        following = None")],
      ["tests/nls/test_newton.py::test_a_pattern_where_petscs_lu_failed_goes_straight_to_the_partial_lu"],
      "a rod built again fails PETSc's LU again (a wasted factorization and the first step solved twice)"),
    M("zero-pivot-memory-not-written", "rodfem/nls/newton.py",
      [("                    _ZERO_PIVOTS[self._pattern] = following\n", "")],
      ["tests/nls/test_newton.py::test_a_pattern_where_petscs_lu_failed_goes_straight_to_the_partial_lu"],
      "the pattern where PETSc's LU failed is not remembered"),
    M("zero-diagonal-always-skips-petscs-lu", "rodfem/nls/newton.py",
      [("        following = _ZERO_PIVOTS.get(self._pattern)", "        following = _ZERO_PIVOTS.get(self._pattern, \"schur\")")],
      ["tests/nls/test_newton.py::test_a_pattern_where_petscs_lu_failed_goes_straight_to_the_partial_lu"],
      "every Jacobian with a zero on its diagonal taken off PETSc's LU (the four-bar, which PETSc's LU solves)"),
    M("serial-partial-lu-no-backward", "rodfem/la/schur.py",
      [("            self.plu.backward(self._no_interface, out)\n", "")],
      ["tests/la/test_scaling.py::test_schur_pc_solves_like_lu_in_serial"],
      "the serial partial LU's apply without its backward sweep"),
    # -- the many-part scenes (issue 26) ---------------------------------------------------------
    M("chain-pivot-at-the-centre", "demos/chain_1000.py",
      [('links[0].point((-0.5 * l, 0.0, 0.0)), name="pivot")', 'links[0].point((0.0, 0.0, 0.0)), name="pivot")')],
      [MANY + "::test_chain_converges_to_the_minimal_coordinates_pendulum"],
      "the chain's first link turns about its centre instead of its end"),
    M("rod-inertia-about-the-end", "demos/_multibody.py",
      [("J = m * (l * l / 12.0 + r * r / 4.0)", "J = m * (l * l / 3.0 + r * r / 4.0)")],
      [MANY + "::test_chain_converges_to_the_minimal_coordinates_pendulum"],
      "the links' moment of inertia about an end instead of the centre"),
    M("prism-vertical-cables-wrong-way", "demos/tensegrity.py",
      [("cables += [((j, i), (j + 1, (i - 1) % 3), np.sqrt(3.0))", "cables += [((j, i), (j + 1, (i + 1) % 3), np.sqrt(3.0))")],
      [MANY + "::test_prism_self_stress_exists_at_150_degrees_with_ratios_1_sqrt3",
       MANY + "::test_prism_rests_in_its_pre_stressed_equilibrium"],
      "the vertical cables to top node i + 1 (the mirror topology): no self-stress at 150 deg"),
    M("prism-vertical-force-ratio", "demos/tensegrity.py",
      [("(j + 1, (i - 1) % 3), np.sqrt(3.0))", "(j + 1, (i - 1) % 3), 1.5)")],
      [MANY + "::test_prism_rests_in_its_pre_stressed_equilibrium"],
      "the vertical cables pre-stressed with force density 1.5 q_h instead of sqrt(3) q_h"),
    M("prism-shared-triangle-single", "demos/tensegrity.py",
      [("1.0 if j in (0, S) else 2.0", "1.0")],
      [MANY + "::test_prism_rests_in_its_pre_stressed_equilibrium"],
      "a tower's shared triangles carry the force density of one prism, not two"),
    M("prism-push-never-ends", "demos/tensegrity.py",
      [("np.array([0.0, f if t < tp else 0.0, 0.0])", "np.array([0.0, f, 0.0])")],
      [MANY + "::test_free_prism_energy_balance_and_momentum"],
      "the push acts for the whole run: the momentum is not the push's impulse"),
    M("net-crossing-half-joined", "demos/cable_net.py",
      [("for k, pt in enumerate(points[1:], 1):", "for k, pt in enumerate(points[2:], 2):")],
      [MANY + "::test_net_static_sag_against_numpy_newton"],
      "one string end at each crossing left unjoined"),
    M("net-pins-unstretched", "demos/cable_net.py",
      [('n, a = p["n"], p["L"] / (p["n"] + 1) * (1 + p["prestretch"])', 'n, a = p["n"], p["L"] / (p["n"] + 1)')],
      [MANY + "::test_net_static_sag_against_numpy_newton"],
      "the edge nodes placed without the pre-stretch (the strings start slack)"),
    # -- bodies of one kind sharing mesh and kernels (rodfem/core/kinds.py) ---------------------------
    M("kind-template-load-values", "rodfem/core/kinds.py",
      [("    pairs += [(a.constant, b.constant) for a, b in zip(template.loads, body.loads)]",
        "    pairs += [(a.constant, a.constant) for a, b in zip(template.loads, body.loads)]")],
      [KINDS + "::test_links_of_one_kind_on_different_meshes"],
      "the other bodies of a kind read the first body's load values"),
    M("kind-template-objects", "rodfem/core/kinds.py",
      [("    swap = counterparts(template, body)\n", "    swap = counterparts(template, template)\n")],
      [KINDS + "::test_equal_links_share_one_mesh_and_kernels"],
      "the other bodies of a kind assembled on the first body's states, step and loads"),
    M("partial-lu-kept-by-size", "rodfem/la/partial_lu.py",
      [("    for a in (ki, kj, src, where, postpone):", "    for a in ():")],
      ["tests/la/test_partial_lu_reuse.py"],
      "the partial LU's kept order and factor pattern found by the matrix's size, not its pattern"),
    M("joint-rank-groups-split", "rodfem/core/system.py",
      [("                parent[root(i)] = root(owner[g])", "                pass")],
      [KINDS + "::test_redundant_joint_in_a_long_chain_is_refused"],
      "the joints' rank check treats joints sharing velocities as independent (a redundant pin passes)"),
    # -- bodies placed whole on ranks (rodfem/core/placement.py) ------------------------------------
    M("placed-multipliers-overlap", "rodfem/fem/assembly.py",
      [("            lo = bodies_end[r] + used.get(r, 0)", "            lo = bodies_end[r]")],
      [PLACED + "::test_chain_on_ranks_equals_serial"],
      "the joints of one rank share their multipliers' rows (each joint's multipliers not after the last one's)"),
    M("placed-step-not-set", "rodfem/core/system.py",
      [("        self._h_set = self.dt if self._ready or not self.distribute else None   # (placed bodies: built later)",
        "        self._h_set = self.dt")],
      [PLACED + "::test_chain_on_ranks_equals_serial"],
      "a body built on its rank keeps h = 1 when the run set the step before the build"),
    M("placed-point-on-rank-start", "rodfem/core/system.py",
      [("                return np.array([layout.body_start[i] + np.asarray(d, np.int64) for d in (pc.q_dofs, pc.v_dofs)])",
        "                return np.array([layout.start + np.asarray(d, np.int64) for d in (pc.q_dofs, pc.v_dofs)])")],
      [PLACED + "::test_chain_on_ranks_equals_serial"],
      "a joint's point on another rank's body read at this rank's dofs"),
    M("placed-error-kept-local", "rodfem/core/system.py",
      [("        found = self.comm.allgather(None if error is None else (type(error), str(error)))\n"
        "        if error is not None:\n            raise error\n",
        "        if error is not None:\n            raise error\n"
        "        found = self.comm.allgather(None)\n")],
      [PLACED + "::test_error_on_one_rank_stops_every_rank"],
      "a body that fails on its rank raises there only (the other ranks wait for it)"),
    # -- the joints on the ranks of their rows (rodfem/core/joint_ranks.py) -----------------------------
    M("placed-offrank-entries-dropped", "rodfem/fem/assembly.py",
      [("        self.local_rows = layout.distributed and (coupling is None or bool(getattr(coupling, \"local_rows\", False)))",
        "        self.local_rows = layout.distributed")],
      [PLACED + "::test_scenes_on_ranks_equal_serial"],
      "no exchange of entries although components (computed on rank 0) add to another rank's rows"),
    M("placed-joint-rows-of-other-rank", "rodfem/core/joint_batch.py",
      [("        self._res_keep = [(g.free_v.ravel() & (g.v_index.ravel() >= lo) & (g.v_index.ravel() < hi),",
        "        self._res_keep = [(g.free_v.ravel(),")],
      [PLACED + "::test_chain_on_ranks_equals_serial"],
      "a joint between ranks adds its momentum rows of the other rank's body into this rank's part"),
    M("placed-joint-work-twice", "rodfem/core/joint_ranks.py",
      [("        counted = [bool(self._here(j.lam_index[:1]).all()) for j in mine]", "        counted = None")],
      [PLACED + "::test_driven_joint_between_ranks_equals_serial"],
      "a driven joint between two ranks' bodies has its supplied work counted on both"),
    M("placed-joint-rows-repeated", "rodfem/core/joint_ranks.py",
      [("        self.repeated = self.rows is not None and len(self.distinct) < len(self.rows)",
        "        self.repeated = False")],
      [PLACED + "::test_driven_joint_between_ranks_equals_serial"],
      "two joints at one point: their residual rows added once (a fancy-indexed += keeps one of the two)"),
    M("placed-multipliers-read-out-misplaced", "rodfem/core/system.py",
      [("            lam[k] = self.X1.getArray(readonly=True)[at]", "            lam[:len(at)] = self.X1.getArray(readonly=True)[at]")],
      [PLACED + "::test_chain_on_ranks_equals_serial"],
      "the history's multipliers of a rank's joints written at the first joints' places"),
    # -- building many joints: moved quadratic forms, the rank check, the sparse blocks (issue 26) -----
    M("moved-form-unchecked", "rodfem/core/joints.py",
      [("                if all(_agrees(g, moved, q, s) for q in", "                if True or all(_agrees(g, moved, q, s) for q in")],
      [RANK + "::test_moved_forms_equal_the_polarized_ones"],
      "a known joint's quadratic form moved to another joint without checking that it is that joint's"),
    M("moved-form-linear-term", "rodfem/core/joints.py",
      [("                moved = (Q, c - QT, e - c @ T + 0.5 * QT @ T)", "                moved = (Q, c, e - c @ T + 0.5 * QT @ T)")],
      [RANK + "::test_moved_forms_equal_the_polarized_ones"],
      "the moved form keeps c (forgets -Q T): every move is refused and each joint polarized again"),
    M("rank-pivot-ignored", "rodfem/la/rank.py",
      [("            if pivots.min() > PIVOT and", "            if pivots.min() > -1.0 and")],
      [RANK + "::test_row_rank_against_the_singular_values",
       "tests/app/test_driver.py::test_a_system_that_cannot_be_built_records_its_error"],
      "the sparse rank check takes every elimination for full rank: redundant joints accepted"),
    M("joint-block-structure-partial", "rodfem/core/joint_batch.py",
      [("        structure_G = structure_q | (self.c != 0)", "        structure_G = structure_q")],
      [JOINTS_3D, MANY],
      "the joints' Jacobian leaves out the entries of G that only c makes nonzero"),
    M("placement-ignores-joints", "rodfem/core/placement.py",
      [("    if len(links):\n        from scipy.sparse import coo_matrix", "    if False:\n        from scipy.sparse import coo_matrix")],
      [PLACED + "::test_placement_keeps_joined_bodies_together"],
      "bodies placed on ranks in the order they were added: a net's every crossing joins two ranks"),
    M("placed-frames-rank0-only", "rodfem/io/snapshot.py",
      [('    if not getattr(problem, "distributed", False):\n        return local, lambda',
        '    if True:\n        return local, lambda')],
      [PLACED + "::test_a_distributed_system_writes_every_bodys_frames"],
      "a run of bodies placed on ranks writes rank 0's bodies' frames only"),
    # -- stability of an equilibrium (rodfem/analysis/stability.py, rodfem/la/pencil.py) ------------
    M("stability-sign", "rodfem/la/pencil.py",
      [("candidates = w[~zero & (w.real > GROWTH * np.abs(w)) & (w.imag >= 0)]",
        "candidates = w[~zero & (w.real < -GROWTH * np.abs(w)) & (w.imag >= 0)]")],
      [STABILITY + "::test_self_weight_column_turns_unstable_at_greenhills_length"],
      "decaying eigenvalues taken for the growing ones: every equilibrium called stable"),
    # -- nets: the serial solver's first LU, the partial LU's graph; pictures of many segments (issue 26) --
    M("partial-lu-multiplier-coupling-dropped", "rodfem/la/partial_lu.py",
      [("            g = coupled\n", "            pass\n")],
      ["tests/la/test_scaling.py::test_a_net_starts_with_the_partial_lu_and_keeps_the_history"],
      "the minimum-degree order blind to the couplings through multipliers: a net's factor 8x fuller"),
    M("net-kept-in-rcm", "rodfem/la/lu_chain.py",
      [('    return "schur" if rcm_envelope(A) > WIDE else "petsc"', '    return "petsc"')],
      ["tests/la/test_scaling.py::test_a_net_starts_with_the_partial_lu_and_keeps_the_history"],
      "a net factored in RCM order (its whole envelope filled)"),
    M("segments-joined", "rodfem/io/animation.py",
      [("    gaps = np.full((len(segments), 1, segments.shape[2]), np.nan)",
        "    gaps = segments[:, 1:]")],
      ["tests/io/test_output.py::test_segments_are_drawn_as_one_broken_line"],
      "separate segments drawn as one line without breaks (the links of a chain joined by strokes)"),
    # -- the parallel set-up and the output of a large run (issue 26) --------------------------------------
    M("partial-lu-tries-never-ended", "rodfem/la/partial_lu.py",
      [("            if best[0] <= NO_BETTER * least:\n                break\n", "")],
      ["tests/la/test_scaling.py::test_partial_lu_tries_end_at_the_pattern_of_the_matrix"],
      "every order tried even when the first one's factor is K's own pattern (AMD's order and count for nothing)"),
    M("partial-lu-tries-end-at-once", "rodfem/la/partial_lu.py",
      [("            if best[0] <= NO_BETTER * least:", "            if True:")],
      ["tests/la/test_scaling.py::test_partial_lu_tries_end_at_the_pattern_of_the_matrix"],
      "the first order kept whatever its fill (RCM the wrong way round: 1.9 times the entries)"),
    M("interior-graph-without-transpose", "rodfem/la/partial_lu.py",
      [("    for (int64_t p = t[r]; p < t[r + 1]; ++p) {", "    for (int64_t p = t[r]; p < t[r]; ++p) {")],
      ["tests/la/test_scaling.py::test_the_interior_graph_is_the_pattern_of_k_plus_its_transpose"],
      "the orders' graph K alone, not K + K^T (an unsymmetric pattern's couplings missed)"),
    M("view-facts-first-frame-only", "rodfem/io/output.py",
      [("                if self.facts is not None:\n                    (self.facts.surface(poly) if i else",
        "                if self.facts is not None and k == 0:\n                    (self.facts.surface(poly) if i else")],
      ["tests/io/test_output_physics.py::test_view_script_has_the_ranges_of_all_frames"],
      "view.py's colour ranges and bounds those of the first frame only (a run from rest: [0, 0])"),
    M("rows-cells-without-the-left-neighbour", "rodfem/io/snapshot.py",
      [("    ca, cb = max(a // k - 1, 0), min(ncells, (b - 1) // k + 2)",
        "    ca, cb = max(a // k, 0), min(ncells, (b - 1) // k + 2)")],
      ["tests/io/test_output.py::test_a_centreline_written_in_rows_has_the_bytes_of_the_whole"],
      "a part's first node at a cell's start gets that cell's value, not the mean of the two cells around it"),
    M("rows-written-at-the-array-start", "rodfem/io/vtk.py",
      [("                _pwrite(fd, block.data, at + 8 + first * block.row)",
        "                _pwrite(fd, block.data, at + 8)")],
      ["tests/io/test_output.py::test_a_centreline_written_in_rows_has_the_bytes_of_the_whole",
       "tests/io/test_output.py::test_two_ranks_write_each_their_rows_of_a_long_centreline"],
      "every writer's rows at the start of each array (the rows before the last writer's overwritten)"),
    M("appended-offset-of-the-values", "rodfem/io/vtk.py",
      [('        attrs["offset"] = str(sum(8 + b.size for b in appended))',
        '        attrs["offset"] = str(sum(8 + b.size for b in appended) + 8)')],
      ["tests/io/test_output.py::test_a_frame_is_appended_raw_binary_that_tiles_its_appended_data"],
      "an appended array's offset past its byte count (VTK reads the values shifted)"),
]


# -- running ------------------------------------------------------------------------------------

def copy_tree(dest, ref=None):
    """The tracked files of the working tree (or of commit `ref`) into `dest`."""
    if ref:
        archive = subprocess.run(["git", "-C", REPO, "archive", ref], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", dest], input=archive, check=True)
        return
    files = subprocess.run(["git", "-C", REPO, "ls-files", "-z"], check=True, capture_output=True,
                           text=True).stdout.split("\0")
    for f in filter(None, files):
        src = os.path.join(REPO, f)
        if os.path.islink(src):   # rodfem/forms -> ../forms, rodfem/demos -> ../demos
            os.makedirs(os.path.dirname(os.path.join(dest, f)), exist_ok=True)
            os.symlink(os.readlink(src), os.path.join(dest, f))
        elif os.path.isfile(src):
            os.makedirs(os.path.dirname(os.path.join(dest, f)), exist_ok=True)
            shutil.copy2(src, os.path.join(dest, f))


CACHE = None   # the run's private JIT cache (XDG_CACHE_HOME), made in main()


def private_cache():
    """A JIT cache of this run's own, seeded with the user's compiled forms: mutated forms compile
    into it one at a time (several processes compiling into one shared cache gave spurious gcc
    and FileNotFound failures), and the user's cache gets none of them."""
    cache = tempfile.mkdtemp(prefix="rodfem-mut-cache-")
    user = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "fenics")
    if os.path.isdir(user):
        shutil.copytree(user, os.path.join(cache, "fenics"), ignore=shutil.ignore_patterns("*.lock"))
    return cache


def environment(copy):
    env = dict(os.environ, PYTHONPATH=copy + os.pathsep + os.environ.get("PYTHONPATH", ""), OMP_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    if CACHE:
        env["XDG_CACHE_HOME"] = CACHE
    return env


PROBE = """
import importlib, sys
from rodfem.app.scene import load
mods = [importlib.import_module(m) for m in ("rodfem", "rodfem.forms", "rodfem.demos", "rodfem.app.cli")]
scene = load("roll-up-2d")
print("\\n".join([m.__file__ for m in mods] + [sys.modules[scene.build.__module__].__file__]))
"""


def preflight(copy):
    """Check that the copy's code is what runs: modules, entry-point scenes, console script, mpirun."""
    env = environment(copy)
    paths = subprocess.run([PYTHON, "-c", PROBE], cwd=copy, env=env, capture_output=True, text=True, timeout=300)
    found = paths.stdout.split()
    # the console script (what the CLI tests run): PYTHONVERBOSE makes Python name every module file it loads
    console = os.path.join(os.path.dirname(PYTHON), "rodfem")
    script = subprocess.run([console, "list"], cwd=copy, env=dict(env, PYTHONVERBOSE="1"), capture_output=True,
                            text=True, timeout=300)
    cli = [line for line in script.stderr.splitlines()
           if line.startswith("# code object from") and "rodfem/app/cli.py" in line]
    mpirun = shutil.which("mpirun")
    mpi = subprocess.run(["timeout", "120", mpirun, "-n", "1", PYTHON, "-c", "import rodfem.forms as f; print(f.__file__)"],
                         cwd=copy, env=env, capture_output=True, text=True) if mpirun else None
    problems = []
    if len(found) != 5 or not all(p.startswith(copy) for p in found):
        problems.append(f"modules/scenes resolve outside the copy: {found or paths.stderr[-500:]}")
    if not cli or not all(copy in line for line in cli):
        problems.append(f"console script {console} does not import the copy: {cli or script.stderr[-300:]}")
    if mpi is not None and not mpi.stdout.strip().startswith(copy):
        problems.append(f"mpirun children do not import the copy: {mpi.stdout.strip() or mpi.stderr[-300:]}")
    return problems


def apply(mutation, copy):
    """Replace the mutation's texts in the copy; returns an error message or None."""
    path = os.path.join(copy, mutation.file)
    if not os.path.exists(path):
        return f"{mutation.file} does not exist"
    text = open(path).read()
    for old, new in mutation.edits:
        count = text.count(old)
        if count != 1:
            return f"stale: the text to replace occurs {count} times in {mutation.file}: {old[:60]!r}"
        text = text.replace(old, new)
    with open(path, "w") as f:
        f.write(text)
    # the mutated text really is what Python will import: no stale bytecode beside it
    shutil.rmtree(os.path.join(os.path.dirname(path), "__pycache__"), ignore_errors=True)
    return None


def failed_tests(junit):
    """Node ids (file::name[param]) of the failed or erroring test cases in a JUnit XML file."""
    failed = []
    if not os.path.exists(junit):
        return failed
    for case in ET.parse(junit).getroot().iter("testcase"):
        if case.find("failure") is not None or case.find("error") is not None:
            module = case.get("classname", "").replace(".", "/") + ".py"
            failed.append(f"{module}::{case.get('name')}")
    return failed


def run_one(mutation, ref=None, all_tests=False, timeout=900):
    """Apply `mutation` to a fresh copy and run its tests; returns a result dict."""
    copy = tempfile.mkdtemp(prefix=f"rodfem-mut-{mutation.name}-")
    t0 = time.time()
    try:
        copy_tree(copy, ref)
        error = apply(mutation, copy)
        if error:
            return {"status": "stale", "detail": error, "failed": [], "seconds": 0.0}
        junit = os.path.join(copy, "junit.xml")
        targets = ["tests"] if all_tests else mutation.tests
        cmd = [PYTHON, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--rootdir", copy, "-o", "addopts=",
               f"--junitxml={junit}", *targets]
        try:
            p = subprocess.run(cmd, cwd=copy, env=environment(copy), capture_output=True, text=True, timeout=timeout)
            code, tail = p.returncode, (p.stdout + p.stderr)[-1500:]
        except subprocess.TimeoutExpired:
            code, tail = "timeout", ""
        failed = failed_tests(junit)
        # 1: some test failed.  Anything else (2: collection error, e.g. a mutation that does not
        # import; timeout) says nothing about the tests and is reported as an error, unless the
        # JUnit file names failed tests and the process died of a signal after writing it (PETSc's
        # finalization crashes when a failed test's traceback still holds a solver).
        status = {0: "survived", 1: "caught"}.get(code, "error")
        if status == "error" and failed and isinstance(code, int) and code < 0:
            status = "caught"
        return {"status": status, "failed": failed, "code": code, "detail": "" if status != "error" else tail,
                "seconds": time.time() - t0}
    finally:
        shutil.rmtree(copy, ignore_errors=True)


def short(node):
    return node.replace("tests/", "").replace(".py::", "::")


def write_table(results, path, title, command):
    def cell(text):
        return text.replace("|", "\\|").replace("\n", " ")

    def caught(r):
        return cell("<br>".join(short(t) for t in r["failed"]) or ("–" if r["status"] != "stale" else r["detail"]))
    lines = [f"# {title}", "", f"`{command}`", "", *table([{**r, "m": m} for m, r in results], [
        ("mutation", lambda r: f"`{r['m'].name}`"), ("what it breaks", lambda r: cell(r["m"].what)),
        ("file", lambda r: f"`{r['m'].file}`"), ("result", "**{status}**"), ("tests that caught it", caught),
        ("time", "{seconds:.0f} s")])]
    n_caught = sum(r["status"] == "caught" for _, r in results)
    lines += ["", f"{n_caught} of {len(results)} mutations caught."]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run these mutations only")
    ap.add_argument("--list", action="store_true", help="list the mutations and their tests")
    ap.add_argument("--ref", help="copy this commit instead of the working tree (e.g. main)")
    ap.add_argument("--all-tests", action="store_true", help="run the whole suite per mutation, not only its tests")
    ap.add_argument("--out", default=os.path.join(REPO, "benchmarks", "mutations.md"), help="the Markdown table")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    if args.only and len(chosen) != len(set(args.only)):
        ap.error(f"unknown mutation in {args.only}; see --list")
    if args.list:
        for m in chosen:
            print(f"{m.name:38s} {m.file:24s} {m.what}")
            for t in m.tests:
                print(f"{'':38s}   {t}")
        return 0
    global CACHE
    CACHE = private_cache()
    try:
        return check(chosen, args, argv)
    finally:
        shutil.rmtree(CACHE, ignore_errors=True)


def check(chosen, args, argv):
    """Run the chosen mutations; the table; 0 if every one was caught."""
    probe = tempfile.mkdtemp(prefix="rodfem-mut-probe-")
    try:
        copy_tree(probe, args.ref)
        problems = preflight(probe)
    finally:
        shutil.rmtree(probe, ignore_errors=True)
    if problems:
        print("preflight failed, mutations would not take effect:\n  " + "\n  ".join(problems), file=sys.stderr)
        return 2
    results, t0 = [], time.time()
    for m in chosen:
        r = run_one(m, args.ref, args.all_tests)
        results.append((m, r))
        print(f"{m.name:38s} {r['status']:9s} {r['seconds']:6.0f} s  {', '.join(short(t) for t in r['failed'])}"
              + (f"\n    {r['detail']}" if r["status"] in ("stale", "error") else ""), flush=True)
    command = "benchmarks/mutations.py " + " ".join(argv if argv is not None else sys.argv[1:])
    title = f"Mutation check ({'tests of ' + args.ref if args.ref else 'working tree'}"
    title += f", {'whole suite' if args.all_tests else 'listed tests'} per mutation, {time.time() - t0:.0f} s)"
    write_table(results, args.out, title, command.strip())
    bad = [m.name for m, r in results if r["status"] != "caught"]
    print(f"\n{len(results) - len(bad)} of {len(results)} caught" + (f"; NOT caught: {', '.join(bad)}" if bad else "")
          + f"  ({time.time() - t0:.0f} s, table in {args.out})")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
