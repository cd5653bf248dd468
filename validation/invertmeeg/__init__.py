"""skf_ref's SKF on invertmeeg's benchmark (issue 46).

- :mod:`validation.invertmeeg.solver`: the adapter, an ``invert.solvers.base.BaseSolver``
  running :func:`skf_ref.apply_skf`, and its registration under the id ``"skf"``;
- :mod:`validation.invertmeeg.forward`: the forward the benchmark runs on here;
- ``python -m validation.invertmeeg --mne-testing-data DIR``: the run, written to
  ``validation/invertmeeg/RESULTS.md`` and ``results.csv`` (see ``__main__``).

Nothing here imports invertmeeg (GPL-3, not a dependency of skf_ref) until the solver module
is imported.
"""
