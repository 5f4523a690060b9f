"""Shared fixtures.  The tests are grouped like the package: core/, fem/, la/, nls/, io/,
analysis/, app/ test rodfem's machinery, models/ the physics of forms/ and the demos' scenes.
Child processes (the console script, mpirun) go through processes.py."""
import pytest
from processes import rodfem as rodfem_cmd


@pytest.fixture
def rodfem():
    """`rodfem(*args, np=None, env=None, timeout=600)`: the console script in a child process."""
    return rodfem_cmd
