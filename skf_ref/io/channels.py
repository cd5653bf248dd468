"""Which channels a prepared SKF uses, and the reference of their data.

- :func:`pick_channels`: the channels of the types asked for (``meg``, ``eeg``, as
  ``mne.pick_types`` names them) that are good in the info and present, and not bad, in the
  forward and in the noise covariance, in the info's order; the others listed by reason and
  logged to the "skf_ref" log (``verbose=``).
- :func:`check_reference`: data and lead field need the same reference (docs/model.md §1).
  EEG data with an average-reference projector, or average referenced already to their
  precision (MNE's default ``set_eeg_reference("average", projection=False)``, float32
  files included), are given the average reference with the lead field; any other
  reference is refused: the forward cannot be given it.
"""

import numpy as np

from .._utils.checks import InputError, InputTypeError, describe
from .._utils.extras import optional
from .._utils.log import logger
from .._utils.precision import average_referenced

__all__ = [
    "channel_kind",
    "channel_types",
    "check_reference",
    "has_average_reference_projector",
    "pick_channels",
]


def has_average_reference_projector(info):
    """Whether ``info`` holds a projector onto the constant vector over its EEG channels.

    Parameters
    ----------
    info : mne.Info

    Returns
    -------
    bool
    """
    for proj in info["projs"]:
        vector = np.asarray(proj["data"]["data"], dtype=float)
        names = proj["data"]["col_names"]
        if vector.shape[0] == 1 and len(names) > 1 and np.ptp(vector) <= 1e-12 * abs(vector[0, 0]):
            return True
    return False


def channel_kind(info, name):
    """``"meg"`` or ``"eeg"``: the block of MNE's whitener the channel ``name`` belongs to."""
    mne = optional("mne", "mne", "make_skf_operator")
    return "eeg" if mne.channel_type(info, info.ch_names.index(name)) == "eeg" else "meg"


def channel_types(meg, eeg):
    """The channel types asked for, checked, in words (``"MEG and EEG"``).

    Examples
    --------
    >>> channel_types("grad", True)
    'gradiometer and EEG'
    """
    if not (isinstance(meg, bool) or meg in ("mag", "grad")):
        raise InputError(f"meg must be True, False, 'mag' or 'grad', got {meg!r}")
    if not isinstance(eeg, bool):
        raise InputTypeError(f"eeg must be True or False, got {describe(eeg)}")
    if not (meg or eeg):
        raise InputError("meg=False and eeg=False pick no channel: ask for MEG, EEG or both")
    words = {False: [], True: ["MEG"], "mag": ["magnetometer"], "grad": ["gradiometer"]}[meg]
    return " and ".join(words + ["EEG"] * eeg)


def pick_channels(info, forward, covariance, meg, eeg):
    """The channels an operator uses, and those it leaves out with the reason.

    Parameters
    ----------
    info : mne.Info
    forward : mne.Forward
    covariance : mne.Covariance
    meg : bool or "mag" or "grad"
    eeg : bool

    Returns
    -------
    used : list of str
        In the info's order.
    dropped : dict
        ``{reason: [names]}`` for the reasons that apply: ``"bad"``, ``"not in the
        forward"``, ``"not in the noise covariance"``.
    """
    mne = optional("mne", "mne", "make_skf_operator")
    types = channel_types(meg, eeg)
    candidates = [info.ch_names[i] for i in mne.pick_types(info, meg=meg, eeg=eeg, exclude=[])]
    in_forward = set(forward["sol"]["row_names"]) - set(forward["info"]["bads"])
    in_covariance = set(covariance["names"]) - set(covariance["bads"])
    reasons = {
        "bad": lambda name: name in info["bads"],
        "not in the forward": lambda name: name not in in_forward,
        "not in the noise covariance": lambda name: name not in in_covariance,
    }
    dropped, used = {reason: [] for reason in reasons}, []
    for name in candidates:
        reason = next((r for r, test in reasons.items() if test(name)), None)
        (dropped[reason] if reason else used).append(name)
    dropped = {reason: names for reason, names in dropped.items() if names}
    if not used:
        good = [name for name in candidates if name not in info["bads"]]
        raise InputError(
            f"no {types} channel is common to the data ({len(good)} good {types} channels, "
            f"e.g. {good[:3]}), the forward ({len(in_forward)}, e.g. {sorted(in_forward)[:3]}) "
            f"and the noise covariance ({len(in_covariance)}, e.g. "
            f"{sorted(in_covariance)[:3]})"
        )
    eeg_used = [name for name in used if channel_kind(info, name) == "eeg"]
    if len(eeg_used) == 1:
        raise InputError(
            f"one EEG channel, {eeg_used[0]!r}, is common to the data, the forward and the "
            "noise covariance: the average reference leaves nothing of a single channel; at "
            "least 2 are needed (or leave EEG out: eeg=False)"
        )
    logger.info("SKF operator: %d of the %d %s channels used", len(used), len(candidates), types)
    for reason, names in dropped.items():
        logger.info("    left out, %s: %d %s", reason, len(names), names)
    return used, dropped


def check_reference(info, data, name):
    """Refuse EEG data that carry neither the average reference nor its projector.

    Parameters
    ----------
    info : mne.Info
    data : ndarray, shape (len(info.ch_names), n_times)
    name : str
        What the data are, for the message.
    """
    mne = optional("mne", "mne", "apply_skf")

    if has_average_reference_projector(info):
        return
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
