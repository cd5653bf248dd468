"""The evidence study v3: what the SKF is worth on the data users have.

``python -m validation.reproduce --jobs 2 --mne-testing-data DIR`` runs it from its
pre-registration (``PREREGISTRATION.md`` here): :mod:`.design` (its constants),
:mod:`.conditions` (sensors, noise, covariance), :mod:`.methods` (the SKF and MNE's methods),
:mod:`.measure` (the metrics), :mod:`.run` (the runs, resumable), :mod:`.rule` (the default),
:mod:`.write` (tables and headline.json).
"""
