"""The P20/N20 study: head models, the scenario, metrics, figures, sweeps, baselines, demo.

- :mod:`.head`: EEG head models (MNE's sphere, the sample subject's BEM) and source spaces;
- :mod:`.scenario`: the paper's two dipoles and their simulated EEG;
- :mod:`.regions`, :mod:`.metrics`: what a reconstruction is scored by;
- :mod:`.plots`: the figures (the only place matplotlib is imported);
- :mod:`.sweep`: grids of settings over seeds, resumable, in parallel;
- :mod:`.baselines`: MNE-Python's inverse methods on the same heads and data;
- :mod:`.demo`: what ``skf-ref demo`` runs.

The study imports the method and needs MNE-Python, nibabel, joblib, tqdm and filelock (the
``study`` extra: its head models and its sweeps say so when one is missing); nothing below it
imports the study. Each module above is a public namespace with its own ``__all__`` (in
``plots``, the package's; its modules are the implementation); ``sizes`` is internal.
"""

__all__: list[str] = []
