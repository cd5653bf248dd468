"""The method: the SKF's model, priors, paths and result, in numpy, scipy and filterpy.

- :mod:`.model`: the state-space model and its checks (docs/model.md §1);
- :mod:`.priors`: PM-SNR and EP-SNR to ``theta0`` and ``q`` (§4); :mod:`.tuning` and
  :mod:`.discrepancy`: priors chosen by the data;
- :mod:`.standardization`: the standardization weights, the one home of eq. (7);
- :mod:`.paths`: the three computational paths (the dense statement of the algorithm, the
  filterpy subclass, the exact spectral path);
- :mod:`.reconstruct`: the entry point that checks once and picks a path;
- :mod:`.result`: the result type every path returns;
- :mod:`.settings`: the recommended setting and the paper's.

It imports nothing from the layers above it (MNE objects and files, the cross-check tools,
the study, the command line), except :class:`~.result.Reconstruction`'s conveniences
``to_stc``, ``to_zarr`` and ``to_dask``, which load :mod:`skf_ref.io` when called.
"""
