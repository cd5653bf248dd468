"""``python -m validation.reproduce``: see :mod:`validation.reproduce`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
