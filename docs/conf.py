"""Sphinx configuration of the bplir-drake documentation.

Build: ``python -m sphinx -W -b html docs docs/_build/html``.  The parameter
reference (``reference/parameters.md``) is generated from the parameters'
own metadata at every build; the command-line reference from the parser.
"""
from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

project = "bplir-drake"
author = "the bplir-drake developers"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.viewcode", "sphinxarg.ext"]
source_suffix = {".md": "markdown"}
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]
html_theme = "furo"
html_title = "bplir-drake"
autodoc_member_order = "bysource"
autodoc_typehints = "none"
nitpicky = False
suppress_warnings = ["myst.xref_missing"]


def _parameters_page() -> str:
    from bplir_drake.params import BLOCKS, parameter_reference

    lines = ["# Parameters", "",
             "Every parameter of the package, generated from the parameters' own "
             "metadata (`bplir_drake/params/`, the one source of truth).  Set them in "
             "a TOML file (`--config FILE.toml`, a table per block) or from Python "
             "(`params.with_(block=dataclasses.replace(params.block, field=value))`).  "
             "`true_plant` and `true_friction` take the fields of `plant` and `friction` "
             "and describe the simulated robot.", ""]
    rows = parameter_reference()
    for block in [b for b in BLOCKS if not b.startswith("true_")]:
        doc = " ".join((BLOCKS[block].__doc__ or "").strip().split("\n\n")[0].split())
        lines += [f"## `[{block}]`", "", doc, "",
                  "| name | unit | range | default | meaning |", "| --- | --- | --- | --- | --- |"]
        for r in rows:
            if r["block"] != block:
                continue
            default = r["default"]
            shown = (str(default).lower() if isinstance(default, bool)
                     else f'"{default}"' if isinstance(default, str) else f"{default}")
            cells = [f"`{r['name']}`", r["unit"], r["range"], f"`{shown}`",
                     r["doc"].replace("|", "\\|")]
            lines.append("| " + " | ".join(c.replace("\n", " ") for c in cells) + " |")
        lines.append("")
    return "\n".join(lines)


def _write_generated(app=None, config=None) -> None:
    target = HERE / "reference" / "parameters.md"
    target.parent.mkdir(exist_ok=True)
    text = _parameters_page()
    if not target.exists() or target.read_text() != text:
        target.write_text(text)


_write_generated()


def setup(app):
    app.connect("config-inited", _write_generated)
