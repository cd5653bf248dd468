"""The module paths of skf_ref 0.2, kept for one release: each imports its new home.

``import skf_ref.dense`` (or ``from skf_ref.tune import tune``) still works in 0.3 and warns
with a ``FutureWarning`` naming the new home; 0.4 removes the old paths. The moves are
listed in CHANGELOG.md. A finder on ``sys.meta_path`` answers for the old names only: it
hands the import system the new module itself, so both names are the same object.
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

__all__ = ["MOVED", "install"]

#: Old module (under ``skf_ref.``) -> its new home.
MOVED = {
    "checks": "_utils.checks",
    "files": "_utils.atomic_files",
    "memory": "_utils.memory",
    "provenance": "_utils.provenance",
    "model": "method.model",
    "priors": "method.priors",
    "tune": "method.tuning",
    "standardization": "method.standardization",
    "result": "method.result",
    "inverse": "method.reconstruct",
    "dense": "method.paths.dense",
    "kalman": "method.paths.filterpy_skf",
    "spectral": "method.paths.spectral",
    "singular": "method.paths.singular_basis",
    "rows": "method.paths.spectral_rows",
    "apply": "io.apply",
    "stc": "io.stc",
    "stream": "io.zarr_dask",
    "comparison": "conformance.compare",
    "suspects": "conformance.mistakes",
    "head": "study.head",
    "simulate": "study.scenario",
    "regions": "study.regions",
    "metrics": "study.metrics",
    "plots": "study.plots",
    "sweep": "study.sweep",
}
_PACKAGE = __name__.split(".")[0]


def _caller_level():
    """The ``stacklevel`` of the first frame outside the import machinery and this module."""
    frame, level = sys._getframe(1), 1
    while frame is not None and (
        frame.f_code.co_filename.startswith("<frozen importlib")
        or frame.f_code.co_filename == __file__
    ):
        frame, level = frame.f_back, level + 1
    return level


class _Alias(importlib.abc.Loader):
    def __init__(self, old, new):
        self.old, self.new = old, new

    def create_module(self, spec):
        warnings.warn(
            f"{self.old} moved to {self.new} in skf_ref 0.3; the old path goes in 0.4 "
            "(CHANGELOG.md lists every move)",
            FutureWarning,
            stacklevel=_caller_level(),
        )
        module = importlib.import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module):
        # the new module is already executed; the import system gave it the old name's
        # spec, and its own is given back
        module.__spec__ = self.spec


class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        package, _, name = fullname.partition(".")
        if package != _PACKAGE or name not in MOVED:
            return None
        new = f"{_PACKAGE}.{MOVED[name]}"
        return importlib.util.spec_from_loader(fullname, _Alias(fullname, new))


def install():
    """Put the finder of the old paths on ``sys.meta_path`` (once)."""
    if not any(isinstance(finder, _Finder) for finder in sys.meta_path):
        sys.meta_path.append(_Finder())
