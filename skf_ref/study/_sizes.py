"""Default sizes of the study's sphere volume grid, for the library and the command line.

A module of constants alone: the command line reads them to build its help without loading
the head models (which need MNE-Python).
"""

__all__ = ["DEFAULT_POSITIONS", "SCENARIO_MIN_POSITIONS"]

#: Positions of the sphere's volume grid unless asked otherwise: about the paper's 3000.
DEFAULT_POSITIONS = 3000
#: Fewest positions the command line asks of a grid: below about 420 (biosemi64) a grid
#: has no position within 15 mm of each of the scenario's sources.
SCENARIO_MIN_POSITIONS = 420
