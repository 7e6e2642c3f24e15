"""Sphinx helpers of the netcosim documentation.

* ``missing-reference``: netcosim's packages re-export names (``netcosim.network.IdealLink``
  is :class:`netcosim.network.ideal.IdealLink`; ``netcosim.Simulation`` is imported lazily
  from :mod:`netcosim.sim`).  The API reference documents each object once, where it is
  defined; a reference to a re-exported name (``:class:`IdealLink``` in the docstring of
  :mod:`netcosim.network`) is resolved by importing it and following ``__module__`` and
  ``__qualname__`` to the documented object.
* ``.. netcosim-api-table::``: the table of ``netcosim.__all__`` (from ``netcosim._API``),
  each name linked to its documentation, with its summary line.
* :class:`PageScraper`: a sphinx-gallery scraper for the interactive timelines.  A block
  that leaves a :class:`pathlib.Path` to an ``.html`` file it wrote in a variable (or a
  list of them) gets each page copied into the built site (``timelines/``) and shown in
  an ``<iframe>`` below the block, as matplotlib figures are shown as images: the page is
  the one the code wrote during this build.
"""

from __future__ import annotations

import importlib
import inspect
import re
import shutil
import sys
import types
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective


def _import(path: str):
    """The object at dotted *path* (a module, or attributes of one), or None."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except Exception:      # noqa: BLE001 - not a module: try a shorter prefix
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        return obj
    return None


def _canonical(obj) -> str | None:
    if obj is None:
        return None
    if inspect.ismodule(obj):
        return obj.__name__
    module, qual = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if isinstance(module, str) and isinstance(qual, str) and module.startswith("netcosim"):
        return f"{module}.{qual}"
    return None


def _resolve_reexport(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "").lstrip("~.")
    module, cls = node.get("py:module"), node.get("py:class")
    candidates = [target]
    if module:
        parts = module.split(".")
        # the current module, its class, then its parent packages (a submodule naming its package's re-export)
        scoped = [f"{module}.{cls}.{target}"] if cls else []
        candidates = scoped + [".".join(parts[:i] + [target]) for i in range(len(parts), 0, -1)] + candidates
    domain = env.get_domain("py")
    for cand in candidates:
        if not cand.startswith("netcosim"):
            continue
        name = _canonical(_import(cand))
        if name is None or name not in domain.objects:
            continue
        newnode = node.deepcopy()
        newnode["reftarget"] = name
        newnode["refspecific"] = False
        return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], name, newnode, contnode)
    # a member named from outside its class (a class's summary line shown on its module's page)
    if module and "." not in target:
        found = [name for name in domain.objects if name.startswith(module + ".") and name.endswith("." + target)]
        if len(found) == 1:
            newnode = node.deepcopy()
            newnode["reftarget"] = found[0]
            return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], found[0], newnode,
                                       contnode)
    # a name defined in another module than the one naming it (``:data:`EVENT_XTOL``` in a sibling)
    suffix = "." + target
    found = [name for name in domain.objects if name.endswith(suffix)]
    if len(found) == 1:
        newnode = node.deepcopy()
        newnode["reftarget"] = found[0]
        return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], found[0], newnode, contnode)
    head = target.split(".")[0]
    for modname, mod in list(sys.modules.items()):
        if modname.startswith("netcosim") and mod is not None and head in vars(mod):
            candidates.append(f"{modname}.{target}")
            break
    # a name that exists in the code but has no page of its own (a private method, an undocumented
    # constant): shown as code, not as a link.  A name that does not import (renamed, removed) stays
    # a warning, so references cannot rot.
    if any(_import(cand) is not None or _member_of(cand) for cand in candidates if cand.startswith("netcosim")):
        return contnode
    return None


def _member_of(path: str) -> bool:
    """Whether *path* names an attribute set on instances (``self.x`` in the class's source)."""
    owner, _, attr = path.rpartition(".")
    cls = _import(owner)
    if not inspect.isclass(cls):
        return False
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return False
    return f"self.{attr}" in source or f"    {attr}:" in source


class ApiTable(SphinxDirective):
    """``netcosim.__all__`` as a table: name, kind and summary line, linked."""

    def run(self):
        import netcosim

        rows = []
        for name, module in netcosim._API.items():
            obj = getattr(netcosim, name)
            canonical = _canonical(obj) or f"netcosim.{module}.{name}"
            kind = "class" if inspect.isclass(obj) else "func" if callable(obj) else "data"
            doc = (inspect.getdoc(obj) or "").strip().split("\n\n")[0].replace("\n", " ") if kind != "data" else ""
            # the summary is read out of its module's context: its cross-references become literals
            doc = re.sub(r":[a-z:]+:`~?([^`<]*?)(?: <[^>]*>)?`", lambda m: f"``{m.group(1).lstrip('.')}``", doc)
            if kind == "data":
                doc = f"``{obj!r}``"
            rows.append(f"   * - :py:{'obj' if kind == 'data' else kind}:`netcosim.{name} <{canonical}>`\n     - {doc}")
        text = ".. list-table::\n   :header-rows: 1\n   :widths: 30 70\n\n   * - name\n     - what\n" + "\n".join(rows)
        container = nodes.section()
        container.document = self.state.document
        self.state.nested_parse(StringList(text.split("\n"), source="netcosim-api-table"), self.content_offset,
                                container)
        return container.children


def _skip_aliases(app, what, name, obj, skip, options):
    """Type aliases (``Task = tuple[int, dict, int]``) are not classes: no page of their own."""
    if isinstance(obj, types.GenericAlias):
        return True
    return None


#: the folder, in each gallery's image folder, where :class:`PageScraper` keeps the pages
PAGES = "timelines"


class PageScraper:
    """Embed the HTML pages a gallery block wrote (see the module's docstring).

    A page is taken once, the first time a block leaves it in a variable: it is kept
    beside the gallery's images (``<gallery>/images/timelines/<example>_<page>.html``, so
    an example that sphinx-gallery does not re-run keeps its page), copied into the built
    site's ``timelines/`` when the build ends, and shown in an iframe *height* px high.
    """

    def __init__(self, height: int = 620):
        self.height = height
        self._seen: set[tuple[str, str]] = set()

    def __repr__(self) -> str:          # sphinx-gallery keys its cache on the conf's repr
        return f"PageScraper(height={self.height})"

    @staticmethod
    def _pages(values):
        for value in values:
            for item in value if isinstance(value, (list, tuple)) else (value,):
                if isinstance(item, Path) and item.suffix == ".html" and item.is_file():
                    yield item

    def __call__(self, block, block_vars, gallery_conf) -> str:
        example = Path(block_vars["src_file"]).stem
        store = Path(block_vars["image_path_iterator"].image_path).parent / PAGES
        rst = []
        for page in sorted(set(self._pages(list(block_vars["example_globals"].values())))):
            key = (example, str(page.resolve()))
            if key in self._seen:
                continue
            self._seen.add(key)
            name = f"{example}_{page.stem}.html"
            store.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(page, store / name)
            # the gallery's pages are one folder below the site's root
            rst.append(f".. raw:: html\n\n   <p><a href=\"../{PAGES}/{name}\">{page.name}</a> "
                       f"(interactive: drag to pan, wheel to zoom)</p>\n"
                       f"   <iframe src=\"../{PAGES}/{name}\" width=\"100%\" height=\"{self.height}\" "
                       f"style=\"border:1px solid #ccc\" loading=\"lazy\"></iframe>\n")
        return "\n\n".join(rst)


def _copy_pages(app, exception):
    """At the end of an HTML build: the galleries' pages into the site's ``timelines/``."""
    if exception is not None or app.builder.format != "html":
        return
    gallery_dirs = app.config.sphinx_gallery_conf.get("gallery_dirs", [])
    for gallery in [gallery_dirs] if isinstance(gallery_dirs, str) else gallery_dirs:
        for page in sorted((Path(app.srcdir) / gallery / "images" / PAGES).glob("*.html")):
            target = Path(app.outdir) / PAGES / page.name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(page, target)


def setup(app):
    app.connect("build-finished", _copy_pages)
    app.connect("missing-reference", _resolve_reexport)
    app.connect("autodoc-skip-member", _skip_aliases)
    app.add_directive("netcosim-api-table", ApiTable)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
