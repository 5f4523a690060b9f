"""Running out of resources ends a run with one line (exit 2) and summary.json status "error",
never a traceback (exit 1) with the summary left at "running" or "completed"."""
import sys

from processes import rodfem_lines, summary

from rodfem.app.cli import main
from rodfem.fem.assembly import BlockLayout

RUN = ["run", "flying-spaghetti-2d", "--set", "n_elements=4", "--set", "t_end=0.1", "--quiet"]


def one_line(err):
    lines = rodfem_lines(err)
    assert len(lines) == 1, err
    return lines[0]


def test_out_of_memory_while_building_is_one_line(monkeypatch, capsys, tmp_path):
    """A MemoryError (numpy could not allocate the matrix: seen under `ulimit -v` at 34,000 elements)."""
    def no_memory(self, entries):
        raise MemoryError("Unable to allocate 63.0 MiB for an array")
    monkeypatch.setattr(BlockLayout, "create_matrix", no_memory)
    assert main([*RUN, "--out", str(tmp_path)]) == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith("rodfem: error: out of memory (Unable to allocate 63.0 MiB") and "fewer elements" in line
    assert summary(tmp_path)["status"] == "error"


def test_pictures_that_cannot_be_drawn_are_known_before_the_run(monkeypatch, capsys, tmp_path):
    """matplotlib that cannot be imported (it failed with a MemoryError after the last step) is
    reported before the output directory is touched: one line, no steps spent."""
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)   # import matplotlib -> ImportError
    assert main([*RUN, "--out", str(tmp_path / "out")]) == 2
    assert one_line(capsys.readouterr().err).startswith("rodfem: error: cannot load matplotlib for the pictures")
    assert not (tmp_path / "out").exists()
