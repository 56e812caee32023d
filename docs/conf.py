"""Sphinx configuration for lsc.

Build: ``pip install ".[docs]" && sphinx-build -W -b html docs docs/_build/html``; the ``docs``
extra brings everything the worked examples run (JAX and diffrax included) and a bundled MathJax.
The worked examples in ``docs/examples`` run at build time (sphinx-gallery), so every number in
them comes from the code.
"""

import os

project = "lsc"
author = "lsc developers"
copyright = "2026, lsc developers"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    # MathJax served from the built site's _static/mathjax, not from a CDN: the pages show
    # their equations without internet access (it sets mathjax_path)
    "sphinx-mathjax-offline",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]

autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
nitpicky = False

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    # LSC_DOCS_QUICK=1 builds the pages without running the examples (for a fast check).
    "plot_gallery": "False" if os.environ.get("LSC_DOCS_QUICK") else "True",
    "abort_on_example_error": True,
    # no docs/sg_execution_times.rst: timings of one build are not source
    "write_computation_times": False,
}

html_theme = "furo"
html_title = "lsc — low-speed crash simulation"
exclude_patterns = ["_build", "examples", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.md5"]
