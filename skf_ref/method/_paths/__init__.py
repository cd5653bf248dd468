"""The three computational paths of the SKF; every one returns the same result.

- :mod:`.dense`: the readable statement of the algorithm, one equation a line, in numpy;
- :mod:`.filterpy_skf`: a thin subclass of filterpy's ``KalmanFilter`` that adds the
  standardization after each update and reuses its RTS smoother;
- :mod:`.spectral` with :mod:`.singular_basis` and :mod:`.spectral_rows`: the exact fast
  path for isotropic priors, in the singular basis of the whitened lead field.

The tests prove the last two equal to the first (docs/model.md §9).
"""
