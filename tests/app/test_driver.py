"""The driver of `rodfem run` (rodfem/app/driver.py) with scenes made in the test: a system whose
build fails ends with its one-line error and summary.json status "error" (a redundant joint ended
in AttributeError: 'System' object has no attribute 'n_elements' from the summary)."""
import pytest
from mpi4py import MPI
from processes import summary

from rodfem import Support, System
from rodfem.app.driver import run_scene
from rodfem.app.scene import Scene, common
from rodfem.core.joints import ground
from rodfem.errors import ConstraintError
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight


def redundant_pin(p, comm=MPI.COMM_WORLD):
    """A beam pinned at its left end twice: by its support and by a joint to the ground."""
    s = System(comm=comm)
    L, init = straight((0, 0), (1, 0))
    a = s.add("beam", PlanarBeam(1.0, 1.0, quadratic(EA=10, GA=10, EI=1)), L, p["n_elements"], initial=init,
              supports=[Support("left", "pinned")])
    s.join(joints.pin, ground((0.0, 0.0)), a.start)
    return s


def test_a_system_that_cannot_be_built_records_its_error(tmp_path):
    scene = Scene("redundant-pin", "a beam pinned twice", common(2, 0.01, 0.02), redundant_pin)
    with pytest.raises(ConstraintError, match="independent"):
        run_scene(scene, out=str(tmp_path))
    s = summary(tmp_path)
    assert s["status"] == "error" and "independent" in s["failure"]["message"]


def test_a_later_command_clears_the_files_of_an_earlier_one(tmp_path):
    """`rodfem modes` then `rodfem run` into one directory: the run leaves no modes.* or linear.*
    behind (they were never cleared), and `linearize` then `static` no matrices either."""
    from rodfem.app.cli import main
    out = str(tmp_path)
    small = ["--set", "n_elements=4"]
    assert main(["modes", "cantilever-2d", *small, "--out", out]) == 0
    assert (tmp_path / "modes.csv").exists()
    assert main(["run", "cantilever-2d", *small, "--set", "t_end=0.02", "--quiet", "--out", out]) == 0
    assert not list(tmp_path.glob("mode*"))
    assert main(["linearize", "cantilever-2d", *small, "--out", out]) == 0
    assert (tmp_path / "E.npz").exists() and (tmp_path / "linear.json").exists()
    assert main(["static", "cantilever-2d", *small, "--out", out]) == 0
    assert not list(tmp_path.glob("*.npz")) or [f.name for f in tmp_path.glob("*.npz")] == ["checkpoint.npz"]
    assert not (tmp_path / "linear.json").exists() and (tmp_path / "loadsteps.csv").exists()
