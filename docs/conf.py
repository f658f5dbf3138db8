"""Sphinx configuration: the pages of docs/ (MyST Markdown) and the API reference from the
docstrings. Build: python -m sphinx -W --keep-going -b html docs docs/_build/html"""

from __future__ import annotations

from pathlib import Path

import nbformat

import ffsm_pin

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "examples"

project = "ffsm-pin"
author = "ffsm-pin developers"
release = version = ffsm_pin.__version__
copyright = "2026, ffsm-pin developers"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "campaigns/*/worst/**", "figures/**"]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
# Links from the pages to files that are not pages (README.md, benchmarks/README.md, source
# files, scenario files) are checked by tests/test_docs.py; Sphinx cannot resolve them.
suppress_warnings = ["myst.xref_missing"]

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_ivar = True  # Attributes sections as fields (autodoc documents the members once)

html_theme = "furo"
html_title = f"ffsm-pin {release}"


def _notebooks_as_pages(app) -> None:
    """examples/*.ipynb -> docs/_generated/<name>.md (markdown cells as they are, code cells
    as Python blocks; the notebooks are executed by the test suite, not by the build)."""
    out = HERE / "_generated"
    out.mkdir(exist_ok=True)
    for path in sorted(EXAMPLES.glob("*.ipynb")):
        nb = nbformat.read(path, as_version=4)
        parts = [f"<!-- generated from examples/{path.name} by docs/conf.py -->"]
        for cell in nb.cells:
            if cell.cell_type == "markdown":
                parts.append(cell.source)
            elif cell.cell_type == "code":
                parts.append("```python\n" + cell.source + "\n```")
        parts.append(f"The notebook: `examples/{path.name}` (run it with Jupyter).")
        (out / f"{path.stem}.md").write_text("\n\n".join(parts) + "\n", encoding="utf-8")


def setup(app) -> None:
    app.connect("builder-inited", _notebooks_as_pages)
