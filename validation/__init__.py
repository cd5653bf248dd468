"""Numerical validation of skf_ref: cross-checks of its computational paths."""
