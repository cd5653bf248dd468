"""Which channels a prepared SKF uses, their types, and the reference of their data.

- :func:`pick_channels`: by default every MEG and EEG channel the data, the forward and the
  noise covariance share, as MNE's ``apply_inverse`` takes them; ``meg=`` and ``eeg=``
  restrict the types (as ``mne.pick_types`` names them). Bad channels (in the info, the
  forward or the covariance) are left out and listed by reason in the "skf_ref" log
  (``verbose=``). Channels are matched by name *and type*: a channel the forward models as
  EEG but the data call ``csd``, ``ecog``, ``misc`` ... is refused by name, since the forward
  cannot model it (:func:`check_channel_types`).
- :func:`has_average_reference_projector`, :func:`check_average_referenced`: data and lead
  field need the same reference (docs/model.md §1).
  EEG data with an average-reference projector over every EEG channel in use, or average
  referenced already to their precision (MNE's default ``set_eeg_reference("average",
  projection=False)``, float32 files included), are given the average reference with the
  lead field; any other reference is refused: the forward cannot be given it. A projector
  that leaves out an EEG channel in use is refused, naming the channels
  (:func:`has_average_reference_projector`), as MNE's ``apply_inverse`` refuses it.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from .._utils.checks import InputError, InputTypeError, describe
from .._utils.extras import optional
from .._utils.log import logger
from .._utils.precision import average_referenced

__all__ = [
    "MODELLED_TYPES",
    "channel_kind",
    "channel_types",
    "check_average_referenced",
    "check_channel_types",
    "has_average_reference_projector",
    "pick_channels",
]

#: The channel types the SKF's forward models: magnetometers, gradiometers and EEG.
MODELLED_TYPES = ("mag", "grad", "eeg")
# MNE's mark of its average-reference projector: the kind FIFFV_PROJ_ITEM_EEG_AVREF, or a
# description "Average EEG reference" (mne._fiff.proj._has_eeg_average_ref_proj)
_AVERAGE_REFERENCE_KIND = 10
_AVERAGE_REFERENCE_DESC = re.compile(r"^Average .* reference$")
_NOT_MODELLED = {
    "csd": "a current source density (Laplacian) is not a potential the forward models: "
    "apply the SKF to the EEG before mne.preprocessing.compute_current_source_density",
}


def _is_average_reference(proj: Any) -> bool:
    """MNE's average-reference projector (by kind or description), or any projector onto
    the constant vector over more than one channel."""
    if proj["kind"] == _AVERAGE_REFERENCE_KIND or _AVERAGE_REFERENCE_DESC.match(proj["desc"]):
        return True
    vector = np.asarray(proj["data"]["data"], dtype=float)
    names = proj["data"]["col_names"]
    return vector.shape[0] == 1 and len(names) > 1 and np.ptp(vector) <= 1e-12 * abs(vector[0, 0])


def has_average_reference_projector(
    info: Any, eeg_names: list[str] | None = None, name: str = "info"
) -> bool:
    """Whether ``info`` holds an average-reference projector over every EEG channel in use.

    A projector that leaves out some of them is refused, naming them: it would give data
    and lead field a reference other than the average of the channels used (MNE's
    ``apply_inverse`` refuses such data too).

    Parameters
    ----------
    info : mne.Info
    eeg_names : list of str, optional
        The EEG channels in use; default the info's good EEG channels.
    name : str
        What the info belongs to, for the message (``"evoked"``).

    Returns
    -------
    bool
        False when the info has no average-reference projector.
    """
    projectors = [proj for proj in info["projs"] if _is_average_reference(proj)]
    if not projectors:
        return False
    if eeg_names is None:
        mne = optional("mne", "mne", "make_skf_operator")
        eeg_names = [info.ch_names[i] for i in mne.pick_types(info, meg=False, eeg=True)]
    covered = {column for proj in projectors for column in proj["data"]["col_names"]}
    missing = [column for column in eeg_names if column not in covered]
    if missing:
        raise InputError(
            f"{name}'s average-reference projector leaves out {len(missing)} of the "
            f"{len(eeg_names)} EEG channels in use: {missing[:10]}; data and lead field would "
            "carry a reference other than the average: make the projector anew over the "
            "channels used (inst.del_proj(), then set_eeg_reference('average', "
            "projection=True)) or mark those channels bad"
        )
    return True


def channel_kind(info: Any, name: str) -> str:
    """``"meg"`` or ``"eeg"``: the block of MNE's whitener the channel ``name`` belongs to."""
    mne = optional("mne", "mne", "make_skf_operator")
    return "eeg" if mne.channel_type(info, info.ch_names.index(name)) == "eeg" else "meg"


def channel_types(meg: bool | str | None, eeg: bool | None) -> str:
    """The channel types asked for, checked, in words (``"MEG and EEG"``).

    ``None`` (the default of both) takes the type when data, forward and covariance share
    it; ``True`` asks for it (an error if there is none); ``False`` leaves it out; ``meg``
    may also be ``"mag"`` or ``"grad"``.

    Examples
    --------
    >>> channel_types("grad", True)
    'gradiometer and EEG'
    >>> channel_types(None, None)
    'MEG or EEG'
    """
    if not (meg is None or isinstance(meg, bool) or meg in ("mag", "grad")):
        raise InputError(f"meg must be None, True, False, 'mag' or 'grad', got {meg!r}")
    if not (eeg is None or isinstance(eeg, bool)):
        raise InputTypeError(f"eeg must be None, True or False, got {describe(eeg)}")
    if meg is False and eeg is False:
        raise InputError("meg=False and eeg=False pick no channel: ask for MEG, EEG or both")
    meg_words = [] if meg is False else ["MEG"]
    if isinstance(meg, str):
        meg_words = ["magnetometer" if meg == "mag" else "gradiometer"]
    joined = " or " if meg is None or eeg is None else " and "
    return joined.join(meg_words + ["EEG"] * (eeg is not False))


def _types_asked(meg: bool | str | None, eeg: bool | None) -> list[str]:
    """The MNE channel types ``meg`` and ``eeg`` allow."""
    types = [meg] if isinstance(meg, str) else [] if meg is False else ["mag", "grad"]
    return types + ["eeg"] * (eeg is not False)


def _forward_types(forward: Any) -> dict[str, str]:
    """``{name: type}`` of the forward's good channels."""
    mne = optional("mne", "mne", "make_skf_operator")
    info = forward["info"]
    return {
        name: mne.channel_type(info, i)
        for i, name in enumerate(info.ch_names)
        if name not in info["bads"]
    }


def check_channel_types(info: Any, expected: dict[str, str], name: str) -> None:
    """Refuse channels whose type in ``info`` is not the type the model gives them.

    Parameters
    ----------
    info : mne.Info
    expected : dict
        ``{channel: type}``: the forward's types (or the operator's) of the channels used.
    name : str
        What the info belongs to, for the message.
    """
    mne = optional("mne", "mne", "make_skf_operator")
    wrong: dict[tuple[str, str], list[str]] = {}
    for i, channel in enumerate(info.ch_names):
        if channel in expected:
            found = mne.channel_type(info, i)
            if found != expected[channel]:
                wrong.setdefault((found, expected[channel]), []).append(channel)
    if not wrong:
        return
    (found, model), names = next(iter(wrong.items()))
    why = _NOT_MODELLED.get(
        found,
        f"skf_ref models {', '.join(MODELLED_TYPES)} channels as the forward types them: "
        "set the types (info.set_channel_types) or leave the channels out (inst.pick)",
    )
    raise InputError(
        f"{name} has {len(names)} channels of type {found!r} that the forward models as "
        f"{model!r} (channels are matched by name and type), e.g. {names[:5]}: {why}"
    )


def pick_channels(
    info: Any,
    forward: Any,
    covariance: Any | None,
    meg: bool | str | None = None,
    eeg: bool | None = None,
) -> tuple[list[str], dict[str, list[str]]]:
    """The channels an operator uses, and those it leaves out with the reason.

    Parameters
    ----------
    info : mne.Info
    forward : mne.Forward
    covariance : mne.Covariance or None
        None: the covariance will be made for the channels picked (``noise_std``).
    meg : None or bool or "mag" or "grad"
    eeg : None or bool
        See :func:`channel_types`.

    Returns
    -------
    used : list of str
        In the info's order.
    dropped : dict
        ``{reason: [names]}`` for the reasons that apply: ``"bad"``, ``"not in the
        forward"``, ``"not in the noise covariance"``, ``"bad in the noise covariance"``
        (held by it, and in its ``bads``), each channel under the first that applies.
    """
    words = channel_types(meg, eeg)
    asked = _types_asked(meg, eeg)
    in_forward = _forward_types(forward)
    check_channel_types(
        info, {k: v for k, v in in_forward.items() if v in asked}, "the data's info"
    )
    kinds = dict(zip(info.ch_names, info.get_channel_types(), strict=True))
    candidates = [channel for channel, kind in kinds.items() if kind in asked]
    in_covariance = held = None
    if covariance is not None:
        held = set(covariance["names"])
        in_covariance = held - set(covariance["bads"])
    reasons = {
        "bad": lambda c: c in info["bads"],
        "not in the forward": lambda c: c not in in_forward,
        "not in the noise covariance": lambda c: held is not None and c not in held,
        # held by the covariance, but marked bad there (its "bads"): MNE leaves it out too
        "bad in the noise covariance": lambda c: (
            in_covariance is not None and c not in in_covariance
        ),
    }
    dropped: dict[str, list[str]] = {reason: [] for reason in reasons}
    used: list[str] = []
    for channel in candidates:
        reason = next((r for r, test in reasons.items() if test(channel)), None)
        (dropped[reason] if reason else used).append(channel)
    dropped = {reason: names for reason, names in dropped.items() if names}
    if not used:
        types_present = {kinds[c] for c in candidates}
        words = _in_words(types_present) if types_present else words
        _nothing_common(info, kinds, candidates, in_forward, in_covariance, words)
    _check_types_used({kinds[c] for c in used}, meg, eeg)
    eeg_used = [c for c in used if kinds[c] == "eeg"]
    if len(eeg_used) == 1:
        raise InputError(
            f"one EEG channel, {eeg_used[0]!r}, is common to the data, the forward and the "
            "noise covariance: the average reference leaves nothing of a single channel; at "
            "least 2 are needed (or leave EEG out: eeg=False)"
        )
    present = _in_words({kinds[c] for c in candidates})
    logger.info("SKF operator: %d of the %d %s channels used", len(used), len(candidates), present)
    for reason, names in dropped.items():
        logger.info("    left out, %s: %d %s", reason, len(names), names)
    return used, dropped


def _in_words(types: set[str]) -> str:
    """Channel types in words: ``{"mag", "grad", "eeg"}`` is ``"MEG and EEG"``."""
    meg = sorted(types - {"eeg"})
    names = {"mag": "magnetometer", "grad": "gradiometer"}
    words = ["MEG"] if len(meg) > 1 else [names[kind] for kind in meg]
    return " and ".join(words + ["EEG"] * ("eeg" in types))


def _nothing_common(info, kinds, candidates, in_forward, in_covariance, words):
    """Refuse a pick with no channel, saying what each input has."""
    good = [c for c in candidates if c not in info["bads"]]
    covariance = ""
    if in_covariance is not None:
        example = sorted(in_covariance)[:3]
        covariance = f" and the noise covariance ({len(in_covariance)}, e.g. {example})"
    raise InputError(
        f"no {words} channel is common to the data ({len(good)} good {words} channels, e.g. "
        f"{good[:3]}; its channel types: {', '.join(sorted(set(kinds.values())))}), the "
        f"forward ({len(in_forward)}, e.g. {sorted(in_forward)[:3]}){covariance}"
    )


def _check_types_used(types: set[str], meg: bool | str | None, eeg: bool | None) -> None:
    """Refuse a pick without a type asked for by name (``True``, ``"mag"``, ``"grad"``)."""
    for flag, value, wanted in (("meg", meg, {"mag", "grad"}), ("eeg", eeg, {"eeg"})):
        wanted = {value} if isinstance(value, str) else wanted
        if value is not None and value is not False and not types & wanted:
            raise InputError(
                f"{flag}={value!r} asks for {'/'.join(sorted(wanted))} channels, but none is "
                "common to the data, the forward and the noise covariance (those they share "
                f"are {', '.join(sorted(types))}); leave {flag}=None to take the types they "
                "share"
            )


def check_average_referenced(info: Any, data: np.ndarray, name: str) -> None:
    """Refuse EEG data (without a projector) whose channel mean is not 0 at every time.

    Average referenced over the good EEG channels, or over all of them before some were
    marked bad, to the data's precision (float32 included).

    Parameters
    ----------
    info : mne.Info
    data : ndarray, shape (len(info.ch_names), n_times)
    name : str
    """
    mne = optional("mne", "mne", "apply_skf")
    eeg = mne.pick_types(info, meg=False, eeg=True, exclude=[])
    good = mne.pick_types(info, meg=False, eeg=True, exclude="bads")
    # referenced over the good channels, or over all of them before some were marked bad
    if average_referenced(data[good]) or average_referenced(data[eeg]):
        return
    if info["custom_ref_applied"]:
        raise InputError(
            f"{name} carries a custom EEG reference other than the average of its channels "
            "(info['custom_ref_applied']); the forward cannot be given it: re-reference "
            "with set_eeg_reference('average')"
        )
    raise InputError(
        f"{name} has neither an average-reference projector nor average-referenced data; "
        "data and lead field need the same reference: set_eeg_reference('average') "
        "gives either (projection=True or False)"
    )
