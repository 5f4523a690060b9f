"""Small C modules of rodfem's own (cffi), compiled once into the JIT cache next to the forms.

`load(prefix, source, declarations)` compiles on first use (rank 0, under the cache lock, the
other ranks load what it compiled) and returns the module (`.ffi`, `.lib`).  The module's name
carries a hash of its source: an edited source compiles anew.
"""
import hashlib
import importlib.util
import os
import sys

from rodfem.fem import compat

_modules = {}


def _build(prefix, source, declarations):
    import cffi
    tag = hashlib.sha1((source + declarations + sys.version).encode()).hexdigest()[:16]
    name = f"{prefix}_{tag}"
    cache = compat.jit_cache_dir()
    os.makedirs(cache, exist_ok=True)
    found = [f for f in os.listdir(cache) if f.startswith(name) and f.endswith(".so")]
    if not found:
        from rodfem.fem.jit import hold
        hold(cache)   # compiling into the cache: under its lock
        ffi = cffi.FFI()
        ffi.cdef(declarations)
        ffi.set_source(name, source, extra_compile_args=["-O3", "-g0"])
        build = os.path.join(cache, f"{name}.build.{os.getpid()}")
        os.makedirs(build, exist_ok=True)
        so = ffi.compile(tmpdir=build)
        target = os.path.join(cache, os.path.basename(so))
        os.replace(so, target)   # atomic: another process sees the whole file or none
        found = [os.path.basename(target)]
    spec = importlib.util.spec_from_file_location(name, os.path.join(cache, found[0]))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load(prefix, source, declarations, comm=None):
    """The compiled module (collective over `comm` the first time: rank 0 compiles)."""
    if prefix not in _modules:
        if comm is not None:
            from rodfem.fem.jit import locked
            with locked(comm):
                if comm.rank == 0:
                    _modules[prefix] = _build(prefix, source, declarations)
                comm.barrier()
        if prefix not in _modules:
            _modules[prefix] = _build(prefix, source, declarations)
    return _modules[prefix]
