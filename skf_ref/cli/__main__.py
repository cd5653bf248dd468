"""``python -m skf_ref.cli``: the same as ``skf-ref``."""

from . import console

console()
