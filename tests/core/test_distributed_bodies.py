"""Bodies placed whole on ranks (`System(distribute=True)`, rodfem/core/placement.py).

Under `mpirun -n R` each body is built on one rank (MPI.COMM_SELF), the bodies of a rank are
assembled as a batch, the multipliers of a joint sit on the rank of its first body, and joints
between bodies of different ranks couple the ranks (rodfem/fem/assembly.py's RankLayout).  The
oracle is the serial run of the same system: every history column (energies, every joint's
multipliers, the constraint residual, the balance) and the final state's norm equal it to 1e-9 on
2 and 3 ranks (measured: 1e-14), on a chain of beams of unequal sizes (crossing joints between
ranks), on rigid boxes with springs and dashpots (components between ranks) and on two free 3D rods
(fewer bodies than ranks: each over all ranks); an error met on one rank only stops every rank (no rank left waiting)."""
import pytest
from processes import assert_same_rows, script_on_ranks

COMMON = """
import json, sys
import numpy as np
from mpi4py import MPI
from rodfem import run
from rodfem.core.system import System
System.distribute = True

def row(res, s, **extra):
    out = dict(extra)
    for c in res.rows[0]:
        if c in ("wall_time", "newton_its") or not isinstance(res.rows[0][c], float):
            continue
        out[c] = float(res.column(c)[-1])
        out[c + "@1"] = float(res.column(c)[1])
    out["|x|"] = float(s.X1.norm())
    out["placed"] = bool(s.distributed) if MPI.COMM_WORLD.size > 1 else True
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(out))
"""

CHAIN = COMMON + """
sys.path.insert(0, "tests/core")
from test_batch import chain
s = chain(7, sizes=[2, 3, 5, 1, 4, 2, 3], ramp=True)
res = run(s, 1e-3, 4e-3)
assert max(abs(e) for e in res.column("balance_error")) <= 1e-12 * max(abs(h) for h in res.column("H"))
row(res, s)
"""

SCENE = COMMON + """
from rodfem.app.scene import load
sc = load(%r)
p = sc.values(%r)
s = sc.build(p, MPI.COMM_WORLD)
res = run(s, p["dt"], %d * p["dt"])
row(res, s)
"""


@pytest.mark.mpi
def test_chain_on_ranks_equals_serial():
    """Seven beams of 1 to 5 elements, pinned end to end, weights growing in time: the history on 2 and 3
    ranks (bodies placed whole: 'placed') is the serial one."""
    serial, *parallel = script_on_ranks(CHAIN, ranks=(1, 2, 3), timeout=300)
    for p in parallel:
        assert p["placed"]
        assert_same_rows(serial, p)


@pytest.mark.mpi
@pytest.mark.parametrize("scene, overrides, steps, placed", [
    ("spring-damper-chain", {"n_bodies": 4}, 4, [True, True]),   # rigid boxes, springs and dashpots
    ("free-flying-3d", {"n_elements": 4}, 3, [True, False]),     # two free 3D rods, a ball joint
])
def test_scenes_on_ranks_equal_serial(scene, overrides, steps, placed):
    """Rigid bodies with components between ranks; two free 3D rods (director constraints, the total momenta
    summed over the ranks), on 3 ranks fewer bodies than ranks (each rod then over all ranks): serial = 2
    ranks = 3 ranks."""
    serial, *parallel = script_on_ranks(SCENE % (scene, overrides, steps), ranks=(1, 2, 3), timeout=300)
    assert [p.pop("placed") for p in parallel] == placed
    serial.pop("placed")
    for p in parallel:
        assert_same_rows(serial, p)


@pytest.mark.mpi
def test_error_on_one_rank_stops_every_rank():
    """The last body's initial values fail (on the rank that builds it only): every rank raises the
    error, the run ends (inside the timeout) with it, and no rank is left waiting."""
    import os
    import shutil
    import subprocess
    import sys

    from processes import REPO, environment
    script = COMMON + """
sys.path.insert(0, "tests/core")
from rodfem import Support
from rodfem.forms import joints
from rodfem.forms.planar_beam import PlanarBeam, quadratic, straight
model = PlanarBeam(1.0, 1.0, quadratic(EA=1e4, GA=1e4, EI=1e2))
s = System()
prev = None
for k in range(4):
    shape = straight((k, 0.0), (k + 1, 0.0))
    if k == 3:
        def broken(x):
            raise ValueError("initial values of b3: broken on purpose")
        shape = (1.0, {"r": broken})
    b = s.add(f"b{k}", model, shape=shape, n_elements=2, supports=[Support("left", "pinned")] if k == 0 else [])
    if prev is not None:
        s.join(joints.pin, prev.end, b.start)
    prev = b
s.build()
"""
    cmd = ["timeout", "60", shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", "2",
           sys.executable, "-c", script]
    env = environment(PYTHONPATH=os.pathsep.join([REPO, os.environ.get("PYTHONPATH", "")]))
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO, timeout=120)
    assert p.returncode not in (0, 124), p.stderr[-2000:]   # (124: timeout, a rank left waiting)
    assert p.stderr.count("broken on purpose") >= 2, p.stderr[-2000:]   # raised on both ranks


@pytest.mark.mpi
def test_adaptive_steps_on_ranks_equal_serial():
    """Adaptive steps (rodfem/analysis/stepping.py measures the error field by field, body by body: the
    groups of the other ranks' bodies are empty on a rank): the same steps, rejections and history on 2
    ranks as serially."""
    script = COMMON + """
sys.path.insert(0, "tests/core")
from rodfem.analysis.stepping import StepControl
from test_batch import chain
s = chain(4, sizes=[2, 3, 2, 3])
res = run(s, 1e-3, 6e-3, control=StepControl(adaptive=True, rtol=1e-4))
row(res, s, steps=float(len(res.rows)), rejected=float(res.stepping["rejected"]))
"""
    serial, parallel = script_on_ranks(script, ranks=(1, 2), timeout=300)
    assert parallel.pop("placed") and serial.pop("placed")
    assert serial["steps"] > 7 and serial["rejected"] >= 1   # (adapted: more steps than 6, some rejected)
    assert_same_rows(serial, parallel)


@pytest.mark.mpi
def test_driven_joint_between_ranks_equals_serial():
    """A driven `angle` joint beside the pin between b1 and b2 (on 2 ranks the bodies of different ranks:
    rodfem/core/joint_ranks.py computes it on both, each adding its own rows, its supplied work counted
    once; two joints at one point: rows added twice on one rank): the energy balance to 1e-12 and the
    history (H, supplied work, every multiplier) on 2 and 3 ranks the serial one."""
    script = COMMON + """
sys.path.insert(0, "tests/core")
from rodfem.forms import joints
from test_batch import chain
s = chain(4, sizes=[2, 3, 2, 3])
s.join(joints.angle, s.bodies["b1"].end, s.bodies["b2"].start, name="motor", drive=lambda t: [40.0 * t * t])
res = run(s, 1e-3, 6e-3)
assert max(abs(e) for e in res.column("balance_error")) <= 1e-12 * max(abs(h) for h in res.column("H"))
assert abs(res.column("supplied")[-1]) > 1e-6
row(res, s)
"""
    serial, *parallel = script_on_ranks(script, ranks=(1, 2, 3), timeout=300)
    for p in parallel:
        assert p.pop("placed")
        assert_same_rows({k: v for k, v in serial.items() if k != "placed"}, p)


@pytest.mark.mpi
def test_a_distributed_system_writes_every_bodys_frames(tmp_path):
    """`rodfem run` of a System(distribute=True) on 2 ranks writes what the serial run writes: the same files
    (every body's centreline and surface frames, the joints' and springs' glyphs, fields.json), the same
    history and the same points and point data to 1e-10.  (Each rank holds only its own bodies: rank 0
    wrote its own bodies' frames only and then failed on the glyphs of the others' joints.)"""
    import os
    import shutil
    import subprocess
    import sys

    import numpy as np
    from processes import REPO, assert_same_history, environment, history

    from rodfem.io.vtk import read_vtp

    def run_on(ranks, out):
        script = ("import sys\nfrom rodfem import System\nfrom rodfem.app.cli import main\nSystem.distribute = True\n"
                  f"sys.exit(main(['run', 'spring-damper-chain', '--set', 'n_bodies=4', '--set', 't_end=0.1', "
                  f"'--quiet', '--out', {str(out)!r}]))")
        cmd = ["timeout", "120", shutil.which("mpirun"), "--allow-run-as-root", "--oversubscribe", "-n", str(ranks),
               sys.executable, "-c", script]
        env = environment(PYTHONPATH=os.pathsep.join([REPO, os.environ.get("PYTHONPATH", "")]))
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO, timeout=180)
        assert p.returncode == 0, p.stderr[-3000:]
        return sorted(str(f.relative_to(out)) for f in out.rglob("*") if f.is_file())
    serial, placed = tmp_path / "serial", tmp_path / "placed"
    files = run_on(1, serial)
    assert run_on(2, placed) == files
    frames = [f for f in files if f.endswith(".vtp")]
    assert len([f for f in frames if f.startswith("centreline/")]) == 4 * 6   # 4 boxes, 6 frames
    for f in frames:
        a, b = read_vtp(serial / f), read_vtp(placed / f)
        assert np.allclose(a.points, b.points, rtol=0, atol=1e-10), f
        assert set(a.point_data) == set(b.point_data), f
        for k in a.point_data:
            assert np.allclose(a.point_data[k].values, b.point_data[k].values, rtol=0, atol=1e-10), (f, k)
    assert (serial / "fields.json").read_text() == (placed / "fields.json").read_text()
    assert_same_history(history(serial), history(placed), 1e-10, skip=("wall_time", "newton_its"))


@pytest.mark.mpi
def test_checkpoints_of_placed_bodies_are_refused_in_one_line(tmp_path):
    """A checkpoint of bodies placed whole on ranks would hold rank 0's bodies only (and the ranks' gathers
    would not match): refused before the first step, one line, summary.json 'error'."""
    from processes import rodfem, rodfem_lines, summary
    out = tmp_path / "out"
    p = rodfem("run", "chain-1000", "--set", "n_links=6", "--set", "t_end=0.02", "--set", "checkpoint_every=2",
               "--quiet", "--out", out, np=2, timeout=300)
    lines = [x for x in rodfem_lines(p.stderr) if x.startswith("rodfem")]
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr[-3000:]
    assert lines == ["rodfem: error: checkpoints of a system whose bodies are placed whole on ranks (distribute=True, "
                     "2 ranks) are not written or read yet: run it without checkpoint_every and --resume, or serially"]
    assert summary(out)["status"] == "error" and not (out / "checkpoint.npz").exists()


def test_placement_keeps_joined_bodies_together():
    """owners(): a chain of 12 bodies on 3 ranks is cut twice and balanced; a net of strings between the
    crossings of a 20 x 20 grid (760 strings, added horizontal ones first, then vertical ones: every
    crossing joins the strings that meet there) is cut along ~20 crossings on 2 ranks (in the order
    added: nearly all of them joined the two ranks)."""
    import numpy as np

    from rodfem.core.placement import owners
    chain = owners([1] * 12, 3, [(k, k + 1) for k in range(11)])
    assert sorted(np.bincount(chain).tolist()) == [4, 4, 4]
    assert sum(chain[k] != chain[k + 1] for k in range(11)) == 2
    n = 20
    strings, meeting = [], {}
    for i in range(n):
        for j in range(n - 1):
            strings.append(((i, j), (i, j + 1)))     # horizontal
    for i in range(n - 1):
        for j in range(n):
            strings.append(((i, j), (i + 1, j)))     # vertical
    for k, ends in enumerate(strings):
        for c in ends:
            meeting.setdefault(c, []).append(k)
    links = [(ks[0], k) for ks in meeting.values() for k in ks[1:]]

    def cut(rank):
        return sum(rank[a] != rank[b] for a, b in links)
    assert cut(owners([1] * len(strings), 2)) >= (n - 2) ** 2          # (no links: the order added)
    placed = owners([1] * len(strings), 2, links)
    assert np.bincount(placed).tolist() == [len(strings) // 2] * 2 and cut(placed) <= 3 * n


@pytest.mark.mpi
def test_statics_of_placed_bodies_equal_serial_without_a_checkpoint(tmp_path):
    """`rodfem static cable-net` on 2 ranks (strings placed whole on ranks): the equilibrium's summary equals
    the serial one to 1e-9, and no step-0 checkpoint is written (it failed at the end, after the solve)."""
    from processes import rodfem, summary
    a, b = tmp_path / "np1", tmp_path / "np2"
    for out, np_ in ((a, None), (b, 2)):
        p = rodfem("static", "cable-net", "--out", out, np=np_, timeout=300)
        assert p.returncode == 0, p.stderr[-3000:]
    sa, sb = summary(a), summary(b)
    assert sa["checkpoint"] and (a / "checkpoint.npz").exists()
    assert not sb["checkpoint"] and not (b / "checkpoint.npz").exists() and sb["status"] == "completed"
    floats = [k for k, v in sa.items() if isinstance(v, float) and "time" not in k]
    assert floats
    for k in floats:
        assert sb[k] == pytest.approx(sa[k], rel=1e-9, abs=1e-12), k
