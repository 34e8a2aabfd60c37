"""Sphinx configuration of sloshrom's documentation site (``make docs``; offline)."""

import inspect
import re
import sys
from importlib.metadata import version as _version
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

project = "sloshrom"
author = "the sloshrom authors"
copyright = "the sloshrom authors"  # noqa: A001 - Sphinx's name
release = _version("sloshrom")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "apigen",
]

# the Markdown pages of docs/ (MyST), their equations and figures
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 4
root_doc = "index"
exclude_patterns = ["_build", "examples", "sg_execution_times.rst",
                    "auto_examples/sg_execution_times.rst", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.json",
                    "**.codeobj.json"]
templates_path = ["_templates"]

# the API reference (docs/_ext/apigen.py writes docs/api/ before the build reads it)
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_default_options = {}
autosummary_generate = False
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
# parameter types as text: a type such as ``array (n,)`` is not a cross-reference to whichever
# attribute happens to be called ``n``
napoleon_use_param = False
napoleon_use_ivar = True



def _absolute_values(app, what, name, obj, options, lines):
    """``|x|`` in a docstring is an absolute value or a norm, never a reST substitution.

    The package's docstrings are read in a terminal too (``help()``), where ``|H1|`` reads as
    it should; the bars are escaped here, outside literals and table rows, so that reST shows
    them as written.
    """
    if what in ("data", "attribute") and lines:
        # a value's documentation is its ``#:`` comment, never its type's docstring
        own = inspect.getdoc(type(obj))
        if own and "\n".join(lines).strip() == own.strip():
            lines.clear()
            return
    for i, line in enumerate(lines):
        row = line.strip()
        if row.startswith("+-") or row.startswith("+=") or (row[:1] == "|" and row[-1:] == "|"
                                                             and row.count("|") > 2):
            continue  # a grid table's row
        parts = re.split(r"(``[^`]*``|`[^`]*`)", line)
        parts[::2] = [re.sub(r"(?<![\\|])\|([^|\s][^|]*?)\|(?![|_])", r"\\|\1\\|", p)
                      for p in parts[::2]]
        lines[i] = "".join(parts)


def _attribute_types(app, what, name, obj, options, lines):
    """An attribute's type as text, the way napoleon shows a parameter's.

    Napoleon writes the Attributes section as ``:ivar x:`` and ``:vartype x: T`` fields, whose
    type Sphinx reads as cross-references by a fuzzy search: ``ndarray (n,)`` would point at
    whichever attribute of the package is called ``n``. The type goes into the description.
    """
    types = {}
    for line in lines:
        m = re.match(r"\s*:vartype ([^:]+): (.*)$", line)
        if m:
            types[m.group(1)] = m.group(2)
    if not types:
        return
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if re.match(r"\s*:vartype [^:]+: ", line):
            continue
        m = re.match(r"(\s*):ivar ([^:]+):(.*)$", line)
        if not m:
            out.append(line)
            continue
        indent, names, text = m.groups()
        body = []  # the field's continuation lines
        while i < len(lines) and lines[i].startswith(indent + " ") and lines[i].strip():
            body.append(lines[i])
            i += 1
        kind = f" (*{types[names]}*)" if names in types else ""
        # ``a, b : T`` is one field for each name (a field's name may not hold a space)
        for one in names.split(", "):
            out += [f"{indent}:ivar {one}:{kind}{text}", *body]
    lines[:] = out


def setup(app):
    """Connect the docstring filter (see :func:`_absolute_values`)."""
    app.connect("autodoc-process-docstring", _absolute_values)
    app.connect("autodoc-process-docstring", _attribute_types, priority=600)  # after napoleon
    # docs/architecture.md draws its diagrams in Mermaid: shown as their source (no JavaScript
    # renderer from a CDN: the site reads offline)
    from pygments.lexers.special import TextLexer
    from sphinx.highlighting import lexers

    lexers["mermaid"] = TextLexer()


# the example gallery: every script of examples/ runs when the site is built
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py",
    "ignore_pattern": r"__init__\.py",
    "download_all_examples": True,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "show_memory": False,
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "backreferences_dir": None,
    "doc_module": (),
    # no page of execution times: sphinx-gallery's loads jQuery and DataTables from a CDN
    "write_computation_times": False,
}

# the site: the PyData theme and its search box; nothing is fetched from the network, neither
# when the site is built nor when it is read (no intersphinx, no analytics, no CDN)
html_theme = "pydata_sphinx_theme"
html_title = f"sloshrom {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "search_bar_text": "Search the docs ...",
    "footer_start": ["copyright"],
    "footer_end": [],
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False
html_static_path = []
