"""Sphinx configuration of the sklearn_hybrid documentation (builds offline).

Build with ``sphinx-build -n -W -b html doc doc/_build/html`` (``-n -W``: every
cross-reference must resolve, warnings are errors).  The gallery runs the
examples in fast mode (``SKLEARN_HYBRID_FAST=1``) unless the variable is set to
something else, so a build takes about a minute; each page then says that it
ran in fast mode.  Examples that need measured data skip with a note when the
data home lacks it.
"""

import os
import sys

sys.path.insert(0, os.path.abspath(".."))
os.environ.setdefault("SKLEARN_HYBRID_FAST", "1")
# sphinx-gallery runs each example from its own folder: a relative data home would point elsewhere
if os.environ.get("SKLEARN_HYBRID_DATA"):
    os.environ["SKLEARN_HYBRID_DATA"] = os.path.abspath(os.environ["SKLEARN_HYBRID_DATA"])
os.environ.setdefault("MPLBACKEND", "Agg")

import sklearn_hybrid  # noqa: E402

project = "sklearn_hybrid"
author = "sklearn_hybrid developers"
copyright = "the sklearn_hybrid developers"
version = release = sklearn_hybrid.__version__

extensions = [
    "sphinx.ext.autodoc",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

# numpydoc: parameters tables from the docstrings, no auto-generated member stubs
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

autodoc_typehints = "none"  # the numpydoc sections already give the types
# Docstrings inherited from scikit-learn (get_params, set_params, score), and ours where they name
# a scikit-learn function, link to scikit-learn's own pages, which an offline build cannot reach;
# every other reference must resolve (-n -W).
nitpick_ignore = [("py:class", "sklearn.pipeline.Pipeline"), ("py:func", "sklearn.metrics.r2_score"),
                  ("py:class", "sklearn.multioutput.MultiOutputRegressor"), ("std:ref", "r2_score"),
                  ("py:func", "sklearn.metrics.get_scorer")]

sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "write_computation_times": False,  # keep generated files out of doc/
    # no cross-links to other projects' online docs: the build must work offline
    "reference_url": {"sklearn_hybrid": None},
}

templates_path = []
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py"]
html_theme = "alabaster"
html_static_path = []
