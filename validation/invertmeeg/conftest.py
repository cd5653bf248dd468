"""pytest: the adapter imports invertmeeg (GPL-3, not a dependency of skf_ref), so its
doctests are collected only where invertmeeg is installed (tests/test_invertmeeg.py says
so when it skips)."""

import importlib.util

collect_ignore = [] if importlib.util.find_spec("invert") else ["solver.py", "__main__.py"]
