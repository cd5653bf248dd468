"""Optional packages, and the extra of skf_ref that installs each.

``python -m pip install .`` from the source tree (skf_ref is not on a package index)
installs what the method needs (numpy, scipy, filterpy, threadpoolctl, matplotlib, pandas).
The rest comes with an extra: ``mne`` (MNE-Python and the file readers it needs), ``study``
(the demo, the sweeps, the report), ``zarr``, ``dask``. A function that needs a missing one
raises :class:`MissingDependencyError` saying which extra to install, and how.
"""

import importlib
import importlib.util
from collections.abc import Iterable
from types import ModuleType

__all__ = ["MissingDependencyError", "optional", "require"]


class MissingDependencyError(ImportError):
    """An optional package is not installed; the message names the extra to install."""


def _message(module: str, extra: str, what: str) -> str:
    return (
        f"{what} needs {module}, which is not installed: install skf_ref's extra '{extra}' "
        f"from its source tree (python -m pip install '.[{extra}]', or a wheel or sdist of it "
        f"with '[{extra}]' after its path), or {module} alone (python -m pip install {module})"
    )


def optional(module: str, extra: str, what: str = "this") -> ModuleType:
    """Import an optional module, or raise :class:`MissingDependencyError` naming the extra.

    Parameters
    ----------
    module : str
        E.g. ``"mne"`` or ``"zarr"``.
    extra : str
        The extra of skf_ref that installs it.
    what : str
        What needs it, for the message.

    Returns
    -------
    module

    Examples
    --------
    >>> optional("math", "none").sqrt(4.0)
    2.0
    >>> optional("no_such_module", "study", "the demo")
    Traceback (most recent call last):
    ...
    skf_ref._utils.extras.MissingDependencyError: the demo needs no_such_module, ...
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name != module.split(".")[0]:
            raise  # the module is there, something it imports is broken
        raise MissingDependencyError(_message(module, extra, what)) from err


def require(modules: Iterable[str], extra: str, what: str) -> None:
    """Raise :class:`MissingDependencyError` unless every module is installed (not imported).

    Parameters
    ----------
    modules : sequence of str
    extra : str
    what : str
    """
    for module in modules:
        if importlib.util.find_spec(module) is None:
            raise MissingDependencyError(_message(module, extra, what))
