"""EEG head models of the P20/N20 study (docs/model.md §5).

Two conductors and two source spaces, all returning a :class:`HeadModel` (lead field,
positions, MNE objects and an :class:`Anatomy`):

- :func:`make_head_model`: MNE's sphere fitted to a montage with a regular grid filling its
  brain compartment (the first release's head; ``skf_ref/study/head/_sphere.py`` explains the
  grid).
- :func:`make_sphere_head`: the sphere with either source space; ``"anatomical"`` is the
  sphere's nearest equivalent of cortex + thalamus.
- :func:`make_realistic_head`: MNE's "sample" subject from MNE's testing dataset, a
  three-layer BEM, and either a grid filling the inner skull or cortex + thalamus from its
  ``aseg.mgz`` (``skf_ref/study/head/_bem.py``). Its forward models are cached on disk
  (:func:`cache_dir`), and the dataset is never downloaded (:func:`find_testing_data`).
- :func:`make_head`: any of the four cells of conductor x source space by name.

Whether a head can hold the scenario is checked where the two meet, in
:func:`skf_ref.study._scenario.simulate`.
"""

import os

from .._sizes import DEFAULT_POSITIONS
from ._bem import (
    LABELS,
    SUBJECT_MONTAGE,
    VOLUME_SPACING_MM,
    make_realistic_head,
    subject_electrodes,
    subject_mni_to_head,
)
from ._data import (
    CACHE_ENV,
    SENSOR_FILES,
    TESTING_FILES,
    cache_dir,
    find_testing_data,
    input_digest,
)
from ._model import CONDUCTORS, SOURCE_SPACES, Anatomy, HeadModel
from ._sphere import (
    ANATOMICAL_SPACING_MM,
    MIN_POSITIONS,
    MINDIST_MM,
    SHELL_DEPTH_MM,
    SPHERE_ANATOMICAL_SPACING_MM,
    THALAMUS_MNI_MM,
    THALAMUS_RADIUS_MM,
    check_montage,
    check_size,
    grid_size,
    make_head_model,
    make_sphere_head,
    required_memory,
    template_mni_to_head,
)

__all__ = [
    "ANATOMICAL_SPACING_MM",
    "CACHE_ENV",
    "CONDUCTORS",
    "LABELS",
    "MINDIST_MM",
    "MIN_POSITIONS",
    "SENSOR_FILES",
    "SHELL_DEPTH_MM",
    "SOURCE_SPACES",
    "SPHERE_ANATOMICAL_SPACING_MM",
    "SUBJECT_MONTAGE",
    "TESTING_FILES",
    "THALAMUS_MNI_MM",
    "THALAMUS_RADIUS_MM",
    "VOLUME_SPACING_MM",
    "Anatomy",
    "HeadModel",
    "cache_dir",
    "check_montage",
    "check_size",
    "find_testing_data",
    "grid_size",
    "input_digest",
    "make_head",
    "make_head_model",
    "make_realistic_head",
    "make_sphere_head",
    "required_memory",
    "subject_electrodes",
    "subject_mni_to_head",
    "template_mni_to_head",
]


def make_head(
    conductor: str = "sphere",
    source_space: str = "volume",
    *,
    n_positions: int = DEFAULT_POSITIONS,
    montage: str = "biosemi64",
    testing_data: str | os.PathLike | None = None,
    cache_dir: str | os.PathLike | None = None,
    spacing_mm: float | None = None,
) -> HeadModel:
    """One cell of conductor x source space.

    Parameters
    ----------
    conductor : {"sphere", "bem"}
        MNE's four-shell sphere, or the sample subject's three-layer BEM.
    source_space : {"volume", "anatomical"}
        A grid filling the brain compartment, or cortex + thalamus.
    n_positions : int
        Positions of the sphere's volume grid (the other source spaces have fixed spacings).
    montage : str
        A built-in montage, or ``"sample"`` (BEM only: the subject's own electrodes and its
        recording's noise covariance, ``head.noise_cov``).
    testing_data : path-like or None
        Root of MNE's testing dataset (BEM heads only; None: MNE's lookup, no download).
    cache_dir : path-like or None
        Cache of the BEM heads' forward models.
    spacing_mm : float or None
        The spacing of the source spaces whose spacing is fixed (all but the sphere's volume
        grid, sized by ``n_positions``); None: each one's default.

    Returns
    -------
    HeadModel
        The head (:func:`make_sphere_head` or :func:`make_realistic_head`).

    Examples
    --------
    >>> make_head("sphere", "anatomical").source_space
    'anatomical'
    """
    from ..._utils.checks import InputError, check_choice

    check_choice("conductor", conductor, CONDUCTORS)
    check_choice("source_space", source_space, SOURCE_SPACES)
    if conductor == "sphere":
        if montage == SUBJECT_MONTAGE:
            raise InputError(
                f"montage={SUBJECT_MONTAGE!r} (the sample subject's own electrodes) needs "
                "conductor='bem', the subject's head; the sphere takes a built-in montage"
            )
        return make_sphere_head(source_space, n_positions, montage, spacing_mm)
    return make_realistic_head(testing_data, source_space, montage, cache_dir, spacing_mm)
