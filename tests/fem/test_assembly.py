"""The assembly of rodfem/fem: the fast Jacobian assembly (rodfem/fem/fastassembly.py) gives
DOLFINx's matrix entry for entry, keeps only the possible nonzeros where they are few (the 3D rod)
and inserts an entry its pattern missed; the block assembly of a system (rodfem/fem/assembly.py)
gives DOLFINx's block matrix; the linear-time collapse of a field is DOLFINx's."""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc
from scenes import built

from rodfem.fem.jit import compile_forms


def test_fast_assembly_is_dolfinx_assembly():
    """The same matrix, entry for entry, for a beam with a clamped end (Dirichlet rows) and a 3D rod
    (a body-fixed end moment: an exterior-facet integral in the Jacobian).  The rod's matrix holds
    only its possible nonzeros (at most a third of DOLFINx's element pattern); the beam's is DOLFINx's."""
    from dolfinx.fem import petsc as fpetsc
    for scene, n in (("cantilever-2d", 12), ("flying-spaghetti-3d", 6)):
        problem = built(scene, n, steps=1)
        nw = problem.newton
        assert nw.assembler.blocks[0].fast is not None
        nw.assembler.jacobian(nw.xv, nw.A)
        B = fpetsc.create_matrix(problem.J)
        fpetsc.assemble_matrix(B, problem.J, bcs=nw.bcs)
        B.assemble()
        C = B.copy()
        C.axpy(-1.0, nw.A, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        assert C.norm() == 0.0 and B.norm() > 0, scene
        kept, full = nw.A.getInfo()["nz_used"], B.getInfo()["nz_used"]
        assert (kept <= full / 3) if scene.endswith("3d") else (kept == full), (scene, kept, full)


@pytest.mark.parametrize("batch", [False, True])
def test_fast_assembly_inserts_an_entry_outside_its_pattern(batch):
    """An entry that is zero at the initial and the random states (a conditional that holds only
    for w > 1e6) but not later: the pattern grows by it, and the matrix is still DOLFINx's, body by
    body and as a batch (rodfem/fem/batch.py, whose views of the structure are made again)."""
    import ufl
    from dolfinx import fem
    from dolfinx import mesh as dmesh
    from dolfinx.fem import petsc as fpetsc

    from rodfem.fem import compat
    from rodfem.fem.assembly import BlockAssembler, BlockLayout, BodyBlock
    mesh = dmesh.create_interval(MPI.COMM_WORLD, 8, [0.0, 1.0])
    P1 = compat.element("P", mesh, 1)
    V = compat.functionspace(mesh, compat.mixed_element([P1] * 4))
    u, v = ufl.TrialFunctions(V), ufl.TestFunctions(V)
    w = fem.Function(compat.functionspace(mesh, P1))
    a = sum(u[i] * v[i] for i in range(4)) * ufl.dx + ufl.conditional(ufl.gt(w, 1e6), w, 0.0) * u[1] * v[0] * ufl.dx
    J = compile_forms({"f": a})["f"]
    x = fem.Function(V)
    F = compile_forms({"f": sum(x[i] * v[i] for i in range(4)) * ufl.dx})["f"]
    assembler = BlockAssembler(BlockLayout(mesh.comm, [V]), [BodyBlock(F, J, x, [])], batch=batch)
    assert assembler.blocks[0].fast is not None
    assert bool(assembler.batches) == (batch and mesh.comm.size == 1)
    A = assembler.create_matrix()
    before = A.getInfo()["nz_used"]
    w.x.array[:] = 1e7
    assembler.jacobian(assembler.vector, A)
    B = fpetsc.create_matrix(J)
    fpetsc.assemble_matrix(B, J)
    B.assemble()
    C = B.copy()
    C.axpy(-1.0, A, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    assert C.norm() == 0.0 and B.norm() > 1e6
    assert A.getInfo()["nz_used"] > before   # the coupling u_1 -> v_0 was inserted
    assembler.jacobian(assembler.vector, A)   # and the next assembly uses the grown pattern
    C = B.copy()
    C.axpy(-1.0, A, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    assert C.norm() == 0.0


def test_linear_time_collapse_is_dolfinx_collapse():
    """StateSpace.collapse (built from the field's element, linear in n) puts every field where
    DOLFINx's quadratic collapse does: the same dofs of W, the same interpolated values."""
    from dolfinx import fem
    from dolfinx import mesh as dmesh

    from rodfem.core.spaces import StateSpace
    from rodfem.forms.cosserat_rod import CosseratRod
    from rodfem.forms.planar_beam import PlanarBeam, quadratic
    for model in (PlanarBeam(1.0, 1.0, quadratic(1.0, 1.0, 1.0), degree=2),
                  CosseratRod(1.0, [1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0])):
        S = StateSpace(dmesh.create_interval(MPI.COMM_WORLD, 17, [0.0, 2.0]), model.fields)
        for f in S.fields:
            def value(x, f=f):
                return np.array([np.sin(3 * x[0] + k) for k in range(f.size)]) if f.shape else np.sin(3 * x[0])
            got, want = fem.Function(S.V), fem.Function(S.V)
            for u, (Vi, dofs) in ((got, S.collapse(f.name)), (want, S.sub(f.name).collapse())):
                fi = fem.Function(Vi)
                fi.interpolate(value)
                u.x.array[dofs] = fi.x.array
            assert np.array_equal(got.x.array, want.x.array), f.name
