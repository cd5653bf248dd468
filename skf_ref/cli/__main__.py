"""``python -m skf_ref.cli``: the same as ``skf-ref``."""

import sys

from . import main

sys.exit(main())
