"""What the documentation needs beyond Sphinx's own extensions, in one small module.

- :func:`api_pages`: for each public module, the names its API page documents (those it
  defines, or re-exports from a private module) and those it only re-exports (linked to
  where they are documented); ``conf.py`` hands it to the autosummary templates.
- :func:`resolve_alias`: a cross-reference to a name by another of its import paths
  (``skf_ref.method._reconstruct.reconstruct`` for ``skf_ref.reconstruct``) finds the page
  where that object is documented.
- :func:`figure_scraper`: the gallery shows the figures the package returns. They are
  ``matplotlib.figure.Figure`` objects made without pyplot, which sphinx-gallery's own
  scraper (``plt.get_fignums()``) does not see.
- ``command-epilog``: a directive that shows a subcommand's examples on the command-line
  page as the terminal shows them.
"""

import ast
import importlib
import inspect
import pkgutil
from pathlib import Path

PACKAGE = "skf_ref"


#: The documented modules: the top level and the packages that declare the names of a
#: layer. Every other module is the implementation of one of them
#: (private: a leading underscore, or listed as such by its package's docstring), and its
#: names are documented where they are declared. tests/test_api.py holds the names of each.
PUBLIC_MODULES = (
    "skf_ref",
    "skf_ref.method",
    "skf_ref.io",
    "skf_ref.conformance",
    "skf_ref.datasets",
    "skf_ref.study",
    "skf_ref.cli",
)


def public_modules(package=PACKAGE):
    """The documented modules (:data:`PUBLIC_MODULES`), sorted."""
    return sorted(name for name in PUBLIC_MODULES if name.split(".")[0] == package)


def all_modules(package=PACKAGE):
    """Every module of the package, private ones included."""
    root = importlib.import_module(package)
    found = pkgutil.walk_packages(root.__path__, f"{package}.")
    return [package, *(info.name for info in found if not info.name.endswith(".__main__"))]


def _kind(obj):
    if inspect.isclass(obj):
        return "exception" if issubclass(obj, BaseException) else "class"
    if inspect.isfunction(obj) or inspect.isbuiltin(obj):
        return "function"
    return "data"


def _imported_from(module):
    """Names a module binds by ``from X import name``: name -> the dotted module X."""
    path = getattr(module, "__file__", None)
    if path is None:
        return {}
    tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    package = module.__name__
    if not path.endswith("__init__.py"):
        package = package.rpartition(".")[0]
    found = {}
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            base = package
            for _ in range(max(node.level - 1, 0)):
                base = base.rpartition(".")[0]
            source = f"{base}.{node.module}" if node.level else node.module
            if node.level and node.module is None:
                source = base
            for alias in node.names:
                found[alias.asname or alias.name] = source
    return found


def _assigned(modname):
    """The names a module assigns at its top level (``NAME = ...``), from its source."""
    path = getattr(importlib.import_module(modname), "__file__", None)
    if path is None:
        return set()
    names = set()
    for node in ast.parse(Path(path).read_text(encoding="utf-8")).body:
        targets = node.targets if isinstance(node, ast.Assign) else []
        if isinstance(node, ast.AnnAssign):
            targets = [node.target]
        names |= {target.id for target in targets if isinstance(target, ast.Name)}
    return names


def _is_private(dotted):
    """Whether names defined in module ``dotted`` are documented where they are declared."""
    return dotted not in PUBLIC_MODULES


def api_pages(package=PACKAGE):
    """The API pages' contents and every alias of a documented name.

    Returns
    -------
    pages : dict
        Module name -> ``{"here": [(name, kind)], "elsewhere": [(name, target, role)]}``:
        ``here`` the names documented on that module's page (defined there, or imported from
        a private module); ``elsewhere`` those it re-exports from a public module, or names
        that the top level documents (``skf_ref.reconstruct``), with where they are.
    aliases : dict
        Dotted name -> the dotted name it is documented under.
    """
    top = importlib.import_module(package)
    top_names = {name: getattr(top, name) for name in top.__all__}
    pages, homes = {}, {}
    for name, obj in top_names.items():
        homes[id(obj)] = f"{package}.{name}"
    for modname in public_modules(package):
        if modname == package:
            continue
        module = importlib.import_module(modname)
        imported = _imported_from(module)
        here, elsewhere = [], []
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if top_names.get(name) is obj:
                elsewhere.append((name, f"{package}.{name}"))
                continue
            if _kind(obj) == "data":
                source = imported.get(name, modname)
            else:
                source = obj.__module__
            if source != modname and not _is_private(source):
                elsewhere.append((name, f"{source}.{name}"))
            else:
                here.append((name, _kind(obj)))
                homes[id(obj)] = f"{modname}.{name}"
        pages[modname] = {"here": here, "elsewhere": elsewhere}
    aliases = {}
    for modname, page in pages.items():
        module = importlib.import_module(modname)
        resolved = []
        for name, default in page["elsewhere"]:
            obj = getattr(module, name)
            target = homes.get(id(obj), default)
            if not target.endswith(f".{name}"):  # a small int or string shared by chance
                target = default
            resolved.append((name, target, _role(obj)))
            aliases[f"{modname}.{name}"] = target
        page["elsewhere"] = resolved
        for name, _ in page["here"]:
            obj = getattr(module, name)
            defined = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
            if None not in defined and _kind(obj) != "data":
                alias = ".".join(defined)
                if alias != f"{modname}.{name}":
                    aliases[alias] = f"{modname}.{name}"
    for name, obj in top_names.items():
        defined = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
        if None not in defined and _kind(obj) != "data":
            aliases.setdefault(".".join(defined), f"{package}.{name}")
    for modname in all_modules(package):  # an implementation module: its package's page
        if modname not in PUBLIC_MODULES:
            home = modname
            while home not in PUBLIC_MODULES:
                home = home.rpartition(".")[0]
            aliases.setdefault(modname, home)
    return pages, aliases


def top_level_data(package=PACKAGE):
    """The package's exported constants: dotted name -> (repr of the value, its doc lines).

    autodoc looks for a constant's ``#:`` comment in the module it is documented from,
    ``skf_ref`` itself, which only loads it from its home (``skf_ref.method._settings``);
    the comment is read from the home here (the first module that assigns it).
    """
    from sphinx.pycode import ModuleAnalyzer

    top = importlib.import_module(package)
    found = {}
    for name in top.__all__:
        value = getattr(top, name)
        if _kind(value) != "data":
            continue
        home = next(  # the module that assigns it, not one that imports it
            module for module in all_modules(package) if name in _assigned(module)
        )
        docs = ModuleAnalyzer.for_module(home).find_attr_docs().get(("", name), [])
        found[f"{package}.{name}"] = (repr(value), [line for line in docs if line])
    return found


def _role(obj):
    return {"class": "class", "exception": "exc", "function": "func", "data": "data"}[_kind(obj)]


def resolve_alias(app, env, node, contnode):
    """``missing-reference``: retry a Python reference under the name its object has here."""
    if node.get("refdomain") != "py":
        return None
    aliases = app.config.skf_aliases
    target = node["reftarget"]
    scopes = [node.get("py:module"), node.get("py:class")]
    candidates = [target]
    if scopes[0]:
        candidates.append(f"{scopes[0]}.{target}")
        if scopes[1]:
            candidates.append(f"{scopes[0]}.{scopes[1]}.{target}")
    domain = env.get_domain("py")

    def resolve(name):
        return domain.resolve_xref(
            env, node["refdoc"], app.builder, node["reftype"], name, node, contnode
        )

    for candidate in candidates:
        head, rest = candidate, ""
        while head:
            if head in aliases:
                return resolve(aliases[head] + rest)
            head, _, last = head.rpartition(".")
            rest = f".{last}{rest}"
    # A short name in a docstring rendered away from its module (``skf_ref.tune``'s
    # docstring names ``BOUND_TOL_DB`` of skf_ref.method._tuning): the one documented object
    # of the package whose dotted name ends with it, if there is exactly one.
    if not target.startswith(f"{PACKAGE}."):
        types = domain.objtypes_for_role(node["reftype"]) or ()
        matches = {
            name
            for name, entry in domain.objects.items()
            if name.startswith(f"{PACKAGE}.")
            and name.endswith(f".{target}")
            and entry.objtype in types
            and not entry.aliased
        }
        if len(matches) == 1:
            return resolve(matches.pop())
    return None


def figure_scraper(block, block_vars, gallery_conf):
    """Save the matplotlib Figures made without pyplot that an example bound to a variable.

    Each is shown once, after the code block that made it. Figures pyplot manages are left
    to sphinx-gallery's own ``"matplotlib"`` scraper, which runs after this one and closes
    them: they are remembered here the first time they are seen, before that.
    """
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    seen = block_vars.setdefault("skf_figures_seen", set())
    paths = []
    for value in list(block_vars["example_globals"].values()):
        if not isinstance(value, Figure) or id(value) in seen:
            continue
        seen.add(id(value))
        if value.canvas.manager is None:
            path = next(block_vars["image_path_iterator"])
            value.savefig(path, dpi=value.dpi)
            paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])


def command_epilog(path):
    """The epilog (the examples) of the subcommand at ``path`` (``"conformance export"``)."""
    import argparse

    from skf_ref.cli import build_parser

    parser = build_parser()
    for name in path.split():
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser.epilog


def _epilog_directive():
    """``.. command-epilog:: reconstruct``: a subcommand's examples as the terminal shows them.

    sphinx-argparse reads an epilog as reStructuredText, but the command line's are laid out
    for a terminal; ``cli.rst`` gives ``:noepilog:`` to each ``argparse`` directive and this
    one after it.
    """
    from docutils import nodes
    from docutils.parsers.rst import Directive

    class CommandEpilog(Directive):
        required_arguments = 1
        final_argument_whitespace = True

        def run(self):
            epilog = command_epilog(self.arguments[0])
            return [nodes.literal_block(epilog, epilog, language="text")] if epilog else []

    return CommandEpilog


def setup(app):
    app.add_config_value("skf_aliases", {}, "env")
    app.connect("missing-reference", resolve_alias)
    app.add_directive("command-epilog", _epilog_directive())
    return {"parallel_read_safe": True, "parallel_write_safe": True}
