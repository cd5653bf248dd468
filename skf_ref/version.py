"""The package version, in one place (setup.cfg reads it too)."""

__all__ = ["__version__"]

__version__ = "0.3.0"
