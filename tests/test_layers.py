"""The two layers of the package: the study imports the method, never the reverse."""

import ast
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "skf_ref"
#: The study: head models, the scenario, metrics, figures, sweeps, the command line.
STUDY = {"head", "simulate", "regions", "metrics", "plots", "sweep", "baselines", "demo", "cli"}


def _module(path):
    return path.relative_to(PACKAGE).with_suffix("").parts


def _imports(path):
    """Every skf_ref module a file imports, at any depth (lazy imports included)."""
    parts = _module(path)
    package = parts[:-1] if parts[-1] != "__init__" else parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[: len(package) - node.level + 1]
            target = (*base, *(node.module.split(".") if node.module else ()))
            names = [alias.name for alias in node.names]
            found |= {target + (name,) for name in names} | {target}
        elif isinstance(node, ast.Import | ast.ImportFrom):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            for name in [module] if module else [alias.name for alias in node.names]:
                if name and name.startswith("skf_ref"):
                    found.add(tuple(name.split(".")[1:]))
    return {target for target in found if target}


def test_the_method_never_imports_the_study():
    for path in PACKAGE.rglob("*.py"):
        if _module(path)[0] in STUDY:
            continue
        study = {target for target in _imports(path) if target[0] in STUDY}
        assert not study, f"{path.name} imports the study: {sorted(study)}"


def test_private_names_stay_in_their_module():
    # a helper two modules need is public in a leaf module
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level:
                private = [
                    a.name for a in node.names if a.name.startswith("_") and a.name[1] != "_"
                ]
                assert not private, f"{path}: imports private {private}"


def test_a_reconstruction_loads_neither_plots_nor_head_models_nor_pandas():
    code = (
        "import sys, numpy as np, skf_ref\n"
        "rng = np.random.default_rng(0)\n"
        "skf_ref.reconstruct(rng.standard_normal((4, 6)), rng.standard_normal((4, 3)),\n"
        "                    noise_std=1.0, theta0=1.0, q=0.1).z\n"
        "loaded = [m for m in ('matplotlib', 'mne', 'pandas', 'skf_ref.head', 'skf_ref.sweep')\n"
        "          if m in sys.modules]\n"
        "print(loaded)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=PACKAGE.parent
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
