"""The three computational paths of the SKF; every one returns the same result.

- ``dense``: the readable statement of the algorithm, one equation a line, in numpy;
- ``filterpy_skf``: a thin subclass of filterpy's ``KalmanFilter`` that adds the
  standardization after each update and reuses its RTS smoother;
- ``spectral`` with ``singular_basis`` (the whitened lead field's SVD), ``recursions``
  (rank-r recursions and their steady state), ``weights`` (``W_t^(alpha)``), ``tiles``
  (the work items) and ``spectral_rows`` (the outputs, any block of rows): the exact fast
  path for isotropic priors, in the singular basis of the whitened lead field.

The tests prove the last two equal to the first (docs/model.md §9).
"""
