"""The names of a reconstruction's outputs, in one place.

Every source-space output has shape (n_sources, n_times), MNE's layout; the conformance
cases and ``compare`` add the scalar innovation log-likelihood.
"""

__all__ = ["ARRAYS", "OUTPUTS"]

#: The (n_sources, n_times) arrays of a :class:`~skf_ref.Reconstruction`.
ARRAYS = ("z", "x", "z_filtered", "x_filtered", "weights")
#: Everything a reconstruction outputs, in the order the conformance cases list it.
OUTPUTS = ("z", "z_filtered", "x", "x_filtered", "weights", "log_likelihood")
