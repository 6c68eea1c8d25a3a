"""Sphinx configuration of the taichi_fdem documentation (``make docs``)."""
import os
import socket
import sys
from urllib.parse import urlparse

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.join(HERE, "_ext"))

import taichi_fdem  # noqa: E402

project = "taichi_fdem"
author = "taichi_fdem authors"
copyright = "taichi_fdem authors, MIT licence"
release = version = taichi_fdem.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "scenefile_ref",
    "error_list",
    "gallery_page",
    "spec_labels",
    "perf_table",
    "array_table",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "accuracy/README.md", "accuracy/results.md", "accuracy/fracture",
                    "skip.md", "stability.md", "guide/README.md",
                    "gallery_items.md", "verification_results.md",
                    "performance_table.md"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 4
html_theme = "furo"
html_title = f"taichi_fdem {release}"
templates_path = []

autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_mock_imports = []
autosummary_generate = True
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_ivar = True
# the slot after "name :" in the package's parameter and return lists often holds a unit or a
# short description ("x0 : (n, 2) float64 [m]") rather than a class name, so it is shown as
# text, not resolved word by word into cross-references
napoleon_use_param = False
napoleon_use_rtype = False
# cross-references to names outside the API reference (private functions) stay plain text
nitpicky = False


def _reachable(url: str, timeout: float = 2.0) -> bool:
    """True when the host of ``url`` accepts a TCP connection (the build runs offline too)."""
    u = urlparse(url)
    try:
        with socket.create_connection((u.hostname, u.port or 443), timeout=timeout):
            return True
    except OSError:
        return False


# intersphinx: a local copy of an inventory (docs/_inv/NAME.inv) is used when present; otherwise
# the inventory is fetched when its host answers, and left out (no link, no warning) when not, so
# the build is the same warning-free one offline.  Taichi's documentation publishes no Sphinx
# inventory, so Taichi is linked only through a local docs/_inv/taichi.inv.
_INVENTORIES = {
    "python": "https://docs.python.org/3/",
    "numpy": "https://numpy.org/doc/stable/",
}
_LOCAL_ONLY = {"taichi": "https://docs.taichi-lang.org/"}
intersphinx_mapping = {}
if os.environ.get("FDEM_DOCS_OFFLINE") != "1":
    for _name, _url in _INVENTORIES.items():
        _local = os.path.join(HERE, "_inv", f"{_name}.inv")
        if os.path.exists(_local):
            intersphinx_mapping[_name] = (_url, _local)
        elif _reachable(_url):
            intersphinx_mapping[_name] = (_url, None)
    for _name, _url in _LOCAL_ONLY.items():
        _local = os.path.join(HERE, "_inv", f"{_name}.inv")
        if os.path.exists(_local):
            intersphinx_mapping[_name] = (_url, _local)
intersphinx_timeout = 5
