"""The real median-nerve SEPs through the SKF and MNE-Python's methods.

``python -m validation.real_sep [--data DIR] [--out DIR]`` loads A0206 (its evoked, FEM
forward and baseline noise covariance) and the 256-channel recording (a fitted sphere),
with and without its neck rows (:mod:`validation.real_sep.neck`), runs every setting of
:mod:`validation.real_sep.settings` and writes ``validation/report/real/REAL.md`` (the
hand-written reading, ``reading.md``, then the criteria of :mod:`validation.real_sep.criteria`
and the neck rule, then the results against them, then what cannot be known), ``real.csv``
(every number) and the figures.
"""
