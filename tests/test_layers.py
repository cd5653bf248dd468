"""The package's layers: each imports only those below it, and nothing imports in a circle."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "skf_ref"
#: The layers, lowest first: a module may import its own layer and those before it.
LAYERS = ("_utils", "method", "io", "conformance", "datasets", "study", "cli")
#: Imports that reach up, each with its reason: none. (The result type's conveniences
#: ``to_stc``, ``to_zarr`` and ``to_dask`` were the last; ``skf_ref.io`` is their one route.)
UPWARD: dict[tuple[str, ...], set[tuple[str, ...]]] = {}
#: Files at the top of the package besides the layers.
TOP = {"__init__.py", "_version.py"}


def _module(path):
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return parts[:-1] if parts[-1] == "__init__" else parts


def _imports(path):
    """Every skf_ref module a file imports, at any depth (lazy imports included)."""
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    package = parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[: len(package) - node.level + 1]
            target = (*base, *(node.module.split(".") if node.module else ()))
            found |= {target + (alias.name,) for alias in node.names} | {target}
        elif isinstance(node, ast.Import | ast.ImportFrom):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            for name in [module] if module else [alias.name for alias in node.names]:
                if name and name.startswith("skf_ref"):
                    found.add(tuple(name.split(".")[1:]))
    modules = {_module(p) for p in PACKAGE.rglob("*.py")}
    return {target for target in found if target in modules}


def _layer(parts):
    return LAYERS.index(parts[0]) if parts and parts[0] in LAYERS else -1


def test_the_top_of_the_package_shows_its_layers():
    entries = {p.name for p in PACKAGE.iterdir() if p.name != "__pycache__"}
    assert entries == TOP | set(LAYERS)
    assert len(entries) <= 10


def test_no_layer_imports_one_above_it():
    for path in PACKAGE.rglob("*.py"):
        here = _module(path)
        if not here or here == ("version",):
            continue
        allowed = UPWARD.get(here, set())
        above = {t for t in _imports(path) if _layer(t) > _layer(here) and t[:2] not in allowed}
        assert not above, f"{'.'.join(here)} imports a layer above it: {sorted(above)}"


def test_no_import_circle():
    """The graph of imports between modules (lazy ones included) has no cycle; a package
    counts as its ``__init__``. The allowed upward conveniences are left out."""
    graph = {}
    for path in PACKAGE.rglob("*.py"):
        here = _module(path)
        allowed = UPWARD.get(here, set())
        graph[here] = {
            target
            for target in _imports(path)
            if target[:2] not in allowed and target != here and here[: len(target)] != target
        }
    state = {}

    def visit(node, trail):
        if state.get(node) == "done":
            return
        assert state.get(node) != "open", f"import circle: {' -> '.join(map('.'.join, trail))}"
        state[node] = "open"
        for other in sorted(graph.get(node, ())):
            visit(other, [*trail, other])
        state[node] = "done"

    for node in sorted(graph):
        visit(node, [node])


def test_private_names_stay_in_their_module():
    # a helper two modules need is public in a leaf module (a private module is imported)
    modules = {_module(p) for p in PACKAGE.rglob("*.py")}
    for path in PACKAGE.rglob("*.py"):
        package = path.relative_to(PACKAGE).with_suffix("").parts[:-1]
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = package[: len(package) - node.level + 1]
                target = (*base, *(node.module.split(".") if node.module else ()))
                private = [
                    a.name
                    for a in node.names
                    if a.name.startswith("_")
                    and a.name[1] != "_"
                    and (*target, a.name) not in modules
                ]
                assert not private, f"{path}: imports private {private}"


@pytest.mark.slow
def test_a_reconstruction_loads_neither_plots_nor_mne_nor_the_study():
    code = (
        "import sys, numpy as np, skf_ref\n"
        "rng = np.random.default_rng(0)\n"
        "skf_ref.reconstruct(rng.standard_normal((4, 6)), rng.standard_normal((4, 3)),\n"
        "                    noise_std=1.0, theta0=1.0, q=0.1).z\n"
        "loaded = [m for m in ('matplotlib', 'mne', 'pandas', 'skf_ref.study', 'skf_ref.io')\n"
        "          if m in sys.modules]\n"
        "print(loaded)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=PACKAGE.parent
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
