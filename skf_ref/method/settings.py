"""The SKF settings the package names: the one it recommends, and the paper's.

A setting is an exponent and a smoother, the two keyword arguments of
:func:`skf_ref.reconstruct` and :func:`skf_ref.apply_skf` they fill:
``reconstruct(L, Y, ..., **PAPER_SETTING)``. Read-only mappings; this module imports
nothing, so the command line can name the defaults without loading numpy.
"""

from types import MappingProxyType

__all__ = ["PAPER_SETTING", "RECOMMENDED_SETTING"]

#: The setting the package recommends and defaults to: the original SKF, exponent 0.5
#: without smoothing. Chosen by a rule committed before the numbers it read (the study's
#: "Which setting, and against what", validation/report/REPORT.md): of the 12 exponent x
#: smoother settings, the one that separates a deep source present from absent (ROC area
#: >= 0.9 at 20 and 30 dB) with the smallest localization error.
RECOMMENDED_SETTING = MappingProxyType({"exponent": 0.5, "smoother": None})
#: The paper's setting (exponent 1.25, its smoother), one argument away:
#: ``reconstruct(L, Y, ..., **PAPER_SETTING)``. In the study it "detects" a deep source that
#: is absent from the data in most runs at 20-30 dB.
PAPER_SETTING = MappingProxyType({"exponent": 1.25, "smoother": "rts-standardized"})
