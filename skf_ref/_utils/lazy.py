"""Public names of a package, imported from their modules on first use.

A package's ``__init__`` declares its names and the module that defines each; nothing is
imported until a name is asked for, so that ``import skf_ref`` (or the command line's
parser) does not load numpy, scipy and filterpy first. MNE-Python's ``lazy_loader`` does
the same.
"""

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["attach"]


def attach(
    package: str, homes: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a package whose names live in its modules.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    homes : mapping of str to str
        Public name -> the module (relative to the package, without the leading dot)
        that defines it.

    Returns
    -------
    __getattr__, __dir__ : callable
        To bind in the package's namespace. A name is looked up once and then kept in the
        package's globals.

    Examples
    --------
    >>> getattr_, dir_ = attach("json", {"JSONDecoder": "decoder"})
    >>> getattr_("JSONDecoder") is importlib.import_module("json.decoder").JSONDecoder
    True
    >>> "JSONDecoder" in dir_()
    True
    """
    namespace = importlib.import_module(package).__dict__

    def __getattr__(name: str) -> Any:
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{homes[name]}", package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:  # the declared names (a package may reach more)
        return sorted(namespace.get("__all__", homes))

    return __getattr__, __dir__
