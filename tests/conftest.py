"""Hypothesis profiles: a reproducible default run and an opt-in random exploration."""

from hypothesis import settings

# The default run (and CI) draws the same examples every time: a red run can be rerun.
settings.register_profile("default", max_examples=150, deadline=None, derandomize=True)
# ``--hypothesis-profile=explore``: thousands of fresh models, and hypothesis's example
# database keeps any failure it finds for the next run.
settings.register_profile("explore", max_examples=5000, deadline=None)
settings.load_profile("default")
