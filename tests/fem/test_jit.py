"""The JIT compilation of forms (rodfem/fem/jit.py): material values are constants, not compiled in."""


def test_material_values_are_constants_not_compiled_in(rodfem, tmp_path):
    """A second run with other stiffness and density values compiles nothing: the JIT cache
    (empty before the first run) gains no file."""
    cache = tmp_path / "cache"
    env = {"XDG_CACHE_HOME": str(cache)}

    def run_with(EA, rhoA):
        p = rodfem("run", "cantilever-2d", "--set", f"EA={EA}", "--set", f"rhoA={rhoA}", "--set", "t_end=0.01",
                   "--quiet", "--out", str(tmp_path / "out"), env=env)
        assert p.returncode == 0, p.stderr[-2000:]
        return sorted(str(f) for f in cache.rglob("*") if f.is_file())
    first = run_with(1e6, 1.0)
    assert first  # the first run compiled its forms into the cache
    assert run_with(3e6, 2.0) == first


def test_a_full_disk_under_the_jit_cache_is_one_line(tmp_path):
    """Files limited to 20 kB while the forms compile into an empty cache (as on a full disk): exit 2,
    one line naming the cache, summary.json 'error' (it was a 65-line traceback from cffi, exit 1,
    the summary left at 'running')."""
    import json
    import subprocess
    import sys

    from processes import environment
    out = tmp_path / "out"
    args = ["run", "roll-up-2d", "--set", "n_elements=4", "--set", "t_end=0.05", "--set", "dt=0.01", "--quiet",
            "--out", str(out)]
    code = ("import resource, sys\nfrom rodfem.app.cli import main\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))\n"
            f"sys.exit(main({args!r}))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                       env=environment(XDG_CACHE_HOME=str(tmp_path / "cache")))
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, p.stderr[-2000:]
    assert lines[0].startswith(f"rodfem: error: the JIT cache {tmp_path / 'cache' / 'fenics'} cannot be written (File too large)")
    assert json.loads((out / "summary.json").read_text())["status"] == "error"


def test_compilation_logs_nothing_through_the_python_api(caplog):
    """Inside `jit.locked` (where forms compile) the C build's INFO lines are dropped: the Python API
    used to print a dozen `INFO:root:x86_64-linux-gnu-gcc ...` lines per form compiled.  Logging at
    INFO works again after the block, and an outer `logging.disable` is restored, not cleared."""
    import logging

    from mpi4py import MPI

    from rodfem.fem import jit
    caplog.set_level(logging.INFO)
    with jit.locked(MPI.COMM_SELF):
        logging.getLogger().info("gcc -shared libffcx_forms.o")
        logging.getLogger().warning("a warning still shows")
    logging.getLogger().info("after the build")
    assert "gcc" not in caplog.text
    assert "a warning still shows" in caplog.text and "after the build" in caplog.text
    logging.disable(logging.WARNING)
    try:
        with jit.locked(MPI.COMM_SELF):
            pass
        assert logging.root.manager.disable == logging.WARNING
    finally:
        logging.disable(logging.NOTSET)


def test_a_form_compiled_outside_rodfem_waits_for_the_lock(tmp_path):
    """A form compiled with dolfinx.fem.form itself (a demo's helper, a test), in a process that imported
    rodfem, takes the cache lock too: while another process holds it, it says so and waits (it
    compiled beside the holder, which took its unfinished source for a dead compilation's and removed
    it: 'cc1: fatal error: libffcx_forms_....c: No such file or directory', seen with two test workers)."""
    import subprocess
    import sys

    from processes import environment, holding_the_lock
    code = ("import rodfem, ufl\nfrom dolfinx import fem, mesh\nfrom mpi4py import MPI\n"
            "m = mesh.create_unit_interval(MPI.COMM_SELF, 3)\n"
            "from rodfem.fem import compat\nV = compat.functionspace(m, compat.element('DG', m, 0))\n"
            "u = fem.Function(V)\n"
            "fem.form(u * u * ufl.dx)\nprint('compiled')\n")
    env = environment(XDG_CACHE_HOME=str(tmp_path), RODFEM_JIT_LOCK_TIMEOUT="1")
    with holding_the_lock(tmp_path):
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode != 0 and "compiled" not in p.stdout, p.stdout + p.stderr[-2000:]
    assert "rodfem: waiting for the JIT cache lock" in p.stderr and "is still held by" in p.stderr
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode == 0 and p.stdout.strip() == "compiled", p.stderr[-2000:]
