"""Sphinx configuration of the sklearn_hybrid documentation (builds offline).

Build with ``sphinx-build -n -W -b html doc doc/_build/html`` (``-n -W``: every
cross-reference must resolve, warnings are errors).

The gallery shows full-size results.  Examples whose full run takes at most
about two minutes on one core (``RUN_IN_DOCS``) are run at full size during the
build; the others are not run, and their pages show the committed full-run
numbers of ``benchmarks/results/`` (rendered below), labelled as such.
``SKLEARN_HYBRID_FAST=1`` runs every example in fast mode instead (a pipeline
check of seconds, labelled so on each page).  The measured data are found as
the tests find them: ``$SKLEARN_HYBRID_DATA``, else ``<repo>/../shared/data``
when that folder exists.
"""

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))
os.environ.setdefault("SKLEARN_HYBRID_FAST", "0")
# the measured files live beside the repository, as for the tests (tests/conftest.py)
SHARED_DATA = HERE.parent.parent / "shared" / "data"
if not os.environ.get("SKLEARN_HYBRID_DATA") and SHARED_DATA.is_dir():
    os.environ["SKLEARN_HYBRID_DATA"] = str(SHARED_DATA)
# sphinx-gallery runs each example from its own folder: a relative data home would point elsewhere
if os.environ.get("SKLEARN_HYBRID_DATA"):
    os.environ["SKLEARN_HYBRID_DATA"] = os.path.abspath(os.environ["SKLEARN_HYBRID_DATA"])
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from _results import render_all, render_snippets  # noqa: E402

#: Results pages (benchmarks/results/<name>.md -> doc/results/<name>.rst), in the order shown.
RESULT_PAGES = ["tasks", "pendulum_theta", "early_stopping", "sensitivity_pendulum", "theta_convergence", "coverage",
                "uncertainty", "profile_budget", "profile_jobs", "laplace", "loop_states", "quickstart",
                "time_to_answer", "units", "float_paths", "network_scales", "long_record", "time_to_theta",
                "closed_loop", "greybox", "identification", "selection_checks", "second_look_null",
                "inconclusive_candidates", "more_validation", "mirror_trades", "anchors_loop", "discovery",
                "discovery_2", "discovery_3", "discovery_4", "discovery_5", "discovery_6", "identification_discovery",
                "flows",
                "varying_theta", "speed", "free_run",
                "sparse_regression", "large_fit", "memory_check", "gpu"]
render_all(RESULT_PAGES)  # -> doc/results/<name>.rst
render_snippets()

#: Examples run at full size during the build (each at most about two minutes on one core).
RUN_IN_DOCS = ["quick_start", "pendulum", "hare_lynx", "sensor_offset"]

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

from sphinx_gallery.sorting import ExplicitOrder  # noqa: E402

sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    # run the cheap examples at full size, or everything in fast mode when asked
    "filename_pattern": (r"/plot_" if os.environ["SKLEARN_HYBRID_FAST"] == "1"
                         else r"/plot_(" + "|".join(RUN_IN_DOCS) + r")\.py$"),
    "subsection_order": ExplicitOrder([f"../examples/{d}" for d in (
        "getting_started", "pendulum", "duffing", "reaction_diffusion", "pendulum_images", "wind_tunnel",
        "light_tunnel", "varying_theta", "closed_loop")]),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "write_computation_times": False,  # keep generated files out of doc/
    # each figure also at twice the pixels (<name>_2_00x.png): sharp at the page's width, where the
    # guide pages show the Quick start's figures larger than their 100 dpi
    "image_srcset": ["2x"],
    # no cross-links to other projects' online docs: the build must work offline
    "reference_url": {"sklearn_hybrid": None},
}

templates_path = []
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py", "_generated/snippets/*"]
html_theme = "alabaster"
html_static_path = ["_static"]
html_css_files = ["wrap.css"]  # printed reports wrap instead of being cut on the right
html_theme_options = {
    "description": "Hybrid models that estimate the science",
    "page_width": "1240px",
    "sidebar_width": "220px",
    "body_max_width": "none",  # code of up to ~100 characters without a scrollbar at 1,280 px
    "fixed_sidebar": False,
}
html_sidebars = {"**": ["about.html", "navigation.html", "searchbox.html"]}
