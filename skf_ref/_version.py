"""The package version, in one place (setup.cfg reads it too)."""

__all__ = ["__version__"]

#: The version of skf_ref (``skf-ref --version`` prints it), as setup.cfg and CHANGELOG.md
#: give it.
__version__ = "0.6.0"
