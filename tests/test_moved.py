"""The module paths of 0.2 still import, each its new home, with a FutureWarning."""

import subprocess
import sys
from pathlib import Path

from skf_ref._utils.moved import MOVED

ROOT = Path(__file__).resolve().parents[1]


def test_every_old_path_imports_its_new_home_with_a_future_warning():
    # a fresh interpreter: an old path imported once is not imported (nor warned about) again
    code = f"""
import importlib, warnings
import skf_ref
for old, new in {MOVED!r}.items():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(f"skf_ref.{{old}}")
    assert module is importlib.import_module(f"skf_ref.{{new}}"), old
    assert module.__spec__.name == f"skf_ref.{{new}}", old
    [warning] = [w for w in caught if w.category is FutureWarning]
    assert f"skf_ref.{{old}} moved to skf_ref.{{new}}" in str(warning.message), warning
print("ok", len({MOVED!r}))
"""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["ok", str(len(MOVED))]


def test_tune_is_the_function_even_after_its_old_module_path_is_imported():
    code = (
        "import warnings, skf_ref\n"
        "warnings.simplefilter('ignore', FutureWarning)\n"
        "from skf_ref.tune import tune, TuneResult\n"
        "import skf_ref.tune\n"
        "assert skf_ref.tune is tune and callable(skf_ref.tune), skf_ref.tune\n"
        "from skf_ref.head import make_head\n"
        "import skf_ref.simulate as simulate\n"
        "print(simulate.__name__)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "skf_ref.study.scenario"


def test_nothing_in_the_package_or_its_tests_uses_an_old_path():
    old = tuple(f"skf_ref.{name}" for name in MOVED)
    for folder in ("skf_ref", "tests", "validation"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.name in ("moved.py", "test_moved.py", "__init__.py") and path.parent.name in (
                "_utils",
                "tests",
                "skf_ref",
            ):
                continue
            for line in path.read_text().splitlines():
                for name in old:
                    words = line.replace("(", " ").replace(",", " ").split()
                    assert not any(w == name or w.startswith(f"{name}.") for w in words), (
                        f"{path.relative_to(ROOT)}: {line.strip()}"
                    )
