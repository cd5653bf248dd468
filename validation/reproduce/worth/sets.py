"""The choice and scored sets: sources drawn near disjoint positions, configurations, noise.

:func:`make_study` draws both sets once (the forward fields of a few thousand points take a
few seconds) in the main process; workers receive the :class:`Study` (arrays only) and
rebuild the head from its keyword arguments.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .design import DRAW_SEEDS, POOL_SEEDS, SETS, SPLIT_SEEDS

__all__ = ["Study", "StudySet", "make_study", "split_positions"]

#: The waveforms' peak moment (A m): the scenario's 10 nAm.
PEAK_MOMENT = 10e-9


@dataclass(frozen=True, eq=False)
class StudySet:
    """One set's sources: thalamic and cortical, three orientations per position.

    Attributes
    ----------
    name : str
        ``"choice"`` or ``"scored"``.
    thalamic, cortical : skf_ref.study.sources.Sources
    """

    name: str
    thalamic: object = field(repr=False)
    cortical: object = field(repr=False)

    @property
    def n_configurations(self):
        """int : One configuration per thalamic source."""
        return len(self.thalamic)

    @staticmethod
    def cortical_of(i):
        """The cortical source of configuration ``i``: position i, orientation i mod 3."""
        i = np.asarray(i)
        return 3 * i + i % 3


@dataclass(frozen=True, eq=False)
class Study:
    """The head's positions and structures, both sets and the reference amplitude.

    Attributes
    ----------
    head_kwargs : dict
        :func:`skf_ref.study.head.make_head`'s arguments.
    positions : ndarray, shape (n_positions, 3)
    thalamus : ndarray of bool, shape (n_positions,)
    sets : dict
        Set name -> :class:`StudySet`.
    a_ref : float
        Median over the choice set's cortical sources of max|Y_clean| of the source alone
        (V): the noise level of the configurations is ``a_ref * 10 ** (-snr / 20)``.
    """

    head_kwargs: dict
    positions: np.ndarray = field(repr=False)
    thalamus: np.ndarray = field(repr=False)
    sets: dict = field(repr=False)
    a_ref: float

    @property
    def n_channels(self):
        """int : Channels of the head."""
        return self.sets["choice"].thalamic.gain.shape[0]

    @property
    def rank(self):
        """int : Rank of the whitener: the channels less the average reference's one."""
        return self.n_channels - 1

    def sigma(self, snr_db):
        """The configurations' noise standard deviation (V) at a peak SNR."""
        return self.a_ref * 10.0 ** (-snr_db / 20.0)

    def pool(self, set_name, design_index, size, n_times):
        """Unit white noise draws of a set and design, shape (size, n_channels, n_times)."""
        seed = POOL_SEEDS[set_name]
        return np.stack(
            [
                np.random.default_rng([seed, design_index, k]).standard_normal(
                    (self.n_channels, n_times)
                )
                for k in range(size)
            ]
        )

    def sources_table(self):
        """Every source of both sets: set, kind, index, position, point (mm), orientation."""
        rows = []
        for name, study_set in self.sets.items():
            for kind in ("thalamic", "cortical"):
                sources = getattr(study_set, kind)
                for k in range(len(sources)):
                    x, y, z = sources.points[k] * 1e3
                    ox, oy, oz = sources.orientations[k]
                    rows.append(
                        (name, kind, k, int(sources.position[k]), x, y, z, ox, oy, oz,
                         bool(sources.on_grid[k]))
                    )  # fmt: skip
        columns = ["set", "kind", "index", "position", "x_mm", "y_mm", "z_mm", "ox", "oy", "oz"]
        return pd.DataFrame(rows, columns=[*columns, "on_grid"])


def split_positions(labels, sizes):
    """The choice and scored positions: thalamic halves per thalamus, cortical draws.

    Parameters
    ----------
    labels : ndarray of str, shape (n_positions,)
        :func:`skf_ref.study.sources.position_labels`.
    sizes : Sizes

    Returns
    -------
    dict
        Set name -> (thalamic positions, cortical positions), int arrays.
    """
    thalamic_rng = np.random.default_rng(SPLIT_SEEDS[0])
    halves = {name: [] for name in SETS}
    for label in ("Left-Thalamus", "Right-Thalamus"):
        permuted = thalamic_rng.permutation(np.flatnonzero(labels == label))
        half = len(permuted) // 2
        halves["choice"].append(permuted[:half])
        halves["scored"].append(permuted[half:])
    cortical = np.random.default_rng(SPLIT_SEEDS[1]).permutation(
        np.flatnonzero(np.char.endswith(labels.astype(str), "Cerebral-Cortex"))
    )
    n_choice, n_scored = sizes.choice_cortical, sizes.scored_cortical
    if n_choice + n_scored > len(cortical):
        raise ValueError(f"the head has {len(cortical)} cortical positions, fewer than asked")
    cortical_sets = {
        "choice": cortical[:n_choice],
        "scored": cortical[n_choice : n_choice + n_scored],
    }
    out = {}
    for name in SETS:
        thalamic = np.concatenate(halves[name])
        if sizes.thalamic is not None:
            thalamic = np.concatenate([h[: sizes.thalamic] for h in halves[name]])[
                : sizes.thalamic
            ]
        out[name] = (thalamic, cortical_sets[name])
    return out


def make_study(head, head_kwargs, sizes):
    """Draw both sets' sources near their positions and compute the reference amplitude.

    Parameters
    ----------
    head : HeadModel
        A cortex + thalamus head.
    head_kwargs : dict
        The arguments that rebuild it (for the workers).
    sizes : Sizes

    Returns
    -------
    Study
    """
    from skf_ref.study.sources import draw_sources, position_labels, position_structures

    labels = position_labels(head)
    sets = {}
    for name, (thalamic, cortical) in split_positions(labels, sizes).items():
        if 3 * len(thalamic) > len(cortical):
            raise ValueError("each configuration needs a cortical position of its own")
        sources = draw_sources(head, np.r_[thalamic, cortical], DRAW_SEEDS[name])
        n = 3 * len(thalamic)
        sets[name] = StudySet(
            name,
            sources.take(np.arange(n)),
            sources.take(np.arange(n, len(sources))),
        )
    peaks = np.abs(sets["choice"].cortical.gain).max(axis=0) * PEAK_MOMENT
    return Study(
        head_kwargs=dict(head_kwargs),
        positions=np.asarray(head.positions),
        thalamus=position_structures(head) == "thalamus",
        sets=sets,
        a_ref=float(np.median(peaks)),
    )
