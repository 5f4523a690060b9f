import os
import shutil
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.dirname(sys.executable)


def rodfem_cmd(*args, np=None, env=None):
    """Run the rodfem console script (optionally under mpirun -n np); returns CompletedProcess."""
    cmd = [os.path.join(BIN, "rodfem"), *args]
    if np:
        cmd = [shutil.which("mpirun"), "-n", str(np), *cmd]
    e = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
             OMPI_MCA_rmaps_base_oversubscribe="1", **(env or {}))
    return subprocess.run(cmd, capture_output=True, text=True, env=e, cwd=REPO, timeout=600)


@pytest.fixture
def rodfem():
    return rodfem_cmd
