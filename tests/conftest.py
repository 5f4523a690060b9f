"""Shared fixtures.  The tests are grouped like the package: core/, fem/, la/, nls/, io/,
analysis/, app/ test rodfem's machinery, models/ the physics of forms/ and the demos' scenes.
Child processes (the console script, mpirun) go through processes.py."""
import pytest
from processes import rodfem as rodfem_cmd


@pytest.fixture
def rodfem():
    """`rodfem(*args, np=None, env=None, timeout=600)`: the console script in a child process."""
    return rodfem_cmd


def pytest_collection_modifyitems(config, items):
    """Groups for pytest-xdist's `--dist loadgroup` (pyproject.toml's addopts: `-n 2`): the tests that
    start `mpirun -n 2` run one after the other on one worker (two ranks each, so never four
    processes on two cores), and the tests of a module with a module-scoped fixture stay on one
    worker (the fixture is built once).  The other tests go to whichever worker is free.  Without
    xdist the marks do nothing."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        scopes = {d.scope for defs in (info.name2fixturedefs.values() if info else ()) for d in defs}
        if item.get_closest_marker("mpi"):
            item.add_marker(pytest.mark.xdist_group("mpi"))
        elif scopes & {"module", "package"}:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
