"""Sphinx configuration of rodfem's documentation.

Build:  .venv/bin/sphinx-build -W -b html docs docs/_build/html   (scripts/install-deps --docs first)

The demos are rendered from their literate source (demos/*.py, prose in comments, code between):
`jupytext` converts each into a MyST Markdown page under docs/demos/ when the build starts, the way
DOLFINx renders its own demos.  The pictures a scene's run writes are shown when docs/pictures.py
has made them (docs/_static/demos/SCENE/: animation.gif, shapes.png, energy.png).
"""
import pathlib
import sys

import jupytext

here = pathlib.Path(__file__).parent
root = here.parent
sys.path.insert(0, str(root))

project = "rodfem"
author = "the rodfem developers"
copyright = "2026, the rodfem developers"
from rodfem import __version__ as release  # noqa: E402

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinxarg.ext"]
# Equations are plain text as in the docstrings: no MathJax, which a browser would fetch from the web.
myst_enable_extensions = ["colon_fence"]
smartquotes = False                     # `--out` stays two hyphens in prose
myst_heading_anchors = 4
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
html_theme = "furo"
html_title = f"rodfem {release}"
html_static_path = ["_static"]
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"
# The demos and benchmark tables link to files of the repository, which are not pages of the site.
suppress_warnings = ["myst.xref_missing"]
nitpicky = False


def demo_pages(app):
    """demos/NAME.py (jupytext's 'light' format: comment blocks are Markdown) -> docs/demos/NAME.md,
    with the scene's pictures appended when docs/pictures.py made them."""
    out = here / "demos"
    out.mkdir(exist_ok=True)
    names = []
    for src in sorted((root / "demos").glob("[!_]*.py")):
        if src.name == "__init__.py":
            continue
        notebook = jupytext.read(src, fmt="py:light")
        text = jupytext.writes(notebook, fmt="md:myst")
        text = text.split("---\n", 2)[2] if text.startswith("---\n") else text     # no notebook metadata
        text = text.replace("```{code-cell}", "```python")
        while "```\n\n```python\n" in text:                                        # one block per run of code
            text = text.replace("```\n\n```python\n", "\n")
        scene = src.stem.replace("_", "-")
        folder = here / "_static" / "demos" / scene
        pictures = [folder / name for name in ("animation.gif", "shapes.png", "energy.png") if (folder / name).exists()]
        if pictures:
            text += "\n## What a run shows\n\n" + f"`rodfem run {scene}` with its default parameters:\n\n"
            text += "".join(f"![{p.stem}](../_static/demos/{scene}/{p.name})\n\n" for p in pictures)
        text += f"\nSource: `demos/{src.name}`\n"
        (out / f"{src.stem}.md").write_text(text)
        names.append(src.stem)
    (out / "index.md").write_text("# Demos\n\nEach demo is a scene: `rodfem show NAME` lists its parameters, "
                                  "`rodfem run NAME` runs it.\n\n```{toctree}\n:maxdepth: 1\n\n"
                                  + "\n".join(names) + "\n```\n")


def plain_bars(app, what, name, obj, options, lines):
    """Docstrings are plain text in the papers' notation: norms and absolute values are |x|
    (never reStructuredText substitutions), and an indented block after a colon is a formula or
    code shown as written.  So: a colon that opens an indented block opens a literal block, and
    the bars and the ``**`` (Python's power, keyword arguments) of every other line are escaped
    (``inline literals`` keep theirs)."""
    literal_indent = None                      # indentation of the line that opened a literal block
    for i, line in enumerate(lines):
        following = next((later for later in lines[i + 1:] if later.strip()), "")
        opens_block = len(following) - len(following.lstrip()) > len(line) - len(line.lstrip())
        if literal_indent is None and line.rstrip().endswith(":") and opens_block:
            line = lines[i] = line.rstrip() + (":" if not line.rstrip().endswith("::") else "")
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and line.strip() and indent <= literal_indent:
            literal_indent = None
        if literal_indent is None:
            parts = line.split("``")
            parts[::2] = [part.replace("|", "\\|").replace("**", "\\*\\*") for part in parts[::2]]
            lines[i] = "``".join(parts)
            if line.rstrip().endswith("::"):
                literal_indent = indent


def setup(app):
    app.connect("builder-inited", demo_pages)
    app.connect("autodoc-process-docstring", plain_bars)
