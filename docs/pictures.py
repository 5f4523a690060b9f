"""Run every scene at its default parameters and keep the pictures it draws, for the demo pages.

    .venv/bin/python docs/pictures.py [SCENE ...]       # all scenes when none is named

Each run writes into a temporary directory; its animation.gif, shapes.png and energy.png are
copied to docs/_static/demos/SCENE/, where docs/conf.py appends them to the scene's demo page.
The pictures are made, not committed (docs/.gitignore): the pages always show what the
current code draws.  A scene whose run fails stops the script with its one-line error.
"""
import pathlib
import shutil
import sys
import tempfile
import time

from rodfem.app.driver import run_scene
from rodfem.app.scene import load, scenes

PICTURES = ("animation.gif", "shapes.png", "energy.png")
here = pathlib.Path(__file__).parent


def pictures(name):
    """Run scene `name` with its defaults; copy its pictures to docs/_static/demos/NAME/."""
    target = here / "_static" / "demos" / name
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    with tempfile.TemporaryDirectory() as out:
        run_scene(load(name), out=out)
        for picture in PICTURES:
            if (pathlib.Path(out) / picture).exists():
                shutil.copy(pathlib.Path(out) / picture, target / picture)
    return sorted(p.name for p in target.iterdir())


def main(names):
    for name in names or scenes():
        started = time.perf_counter()
        made = pictures(name)
        print(f"{name:28s} {time.perf_counter() - started:6.1f} s  {' '.join(made)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
