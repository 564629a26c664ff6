"""Sphinx configuration of the agvctl documentation.

Build:  sphinx-build -W --keep-going -b html docs docs/_build/html
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import pkgutil
import sys
from pathlib import Path

import agvctl

ROOT = Path(__file__).resolve().parent.parent
os.environ.setdefault("MPLBACKEND", "Agg")

# the command lines the guides show, run now: each page includes what its command printed in this build
sys.path.insert(0, str(Path(__file__).resolve().parent))
from console_outputs import write_outputs  # noqa: E402

write_outputs()

project = "agvctl"
author = "the agvctl authors"
copyright = "2026, the agvctl authors"
release = agvctl.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated", "decisions/README.md", "guide/broken-controllers.md", "benchmarks/regenerate.py", "auto_examples/*.ipynb"]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3

autosummary_generate = True
autodoc_typehints = "none"
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False


def _constructor_fields() -> dict[str, list[str]]:
    """The constructor's fields of every agvctl dataclass, by each dotted name it has in a module.

    A dataclass's ``Parameters`` section documents them (agvctl.config.document_fields writes it from the fields),
    so the class template leaves them out of the members it lists, instead of showing each description twice.
    """
    fields: dict[str, list[str]] = {}
    for info in pkgutil.walk_packages(agvctl.__path__, "agvctl."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if isinstance(obj, type) and dataclasses.is_dataclass(obj):
                fields[f"{info.name}.{name}"] = [f.name for f in dataclasses.fields(obj) if f.init]
    return fields


autosummary_context = {"constructor_fields": _constructor_fields()}


sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "experiments" / "gallery"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
}

html_theme = "pydata_sphinx_theme"
html_title = f"agvctl {release}"
html_static_path = ["_static"]
html_css_files = ["agvctl.css"]
templates_path = ["_templates"]
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
