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
