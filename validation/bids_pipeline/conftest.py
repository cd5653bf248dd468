"""pytest: ``config.py`` is MNE-BIDS-pipeline's configuration, read by the pipeline with its
paths in the environment (``__main__.py`` sets them), not a module to import on its own."""

collect_ignore = ["config.py"]
