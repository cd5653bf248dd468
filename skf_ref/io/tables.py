"""EEG data in CSV files, in whatever layout people write them, or a clear refusal.

Channels are rows and times are columns (the package's shapes, docs/model.md §1); a first
column of channel names and a first row of times in seconds are optional. The layout is
read off the content: a name is text, and a first row of numbers is a row of times when
they increase by equal steps (a channel's samples never do). What fits none of these
(channels in columns, a row that could be times or data) is refused with the expected
layout; nothing is transposed or dropped silently. A UTF-8 byte-order mark (Excel's
"CSV UTF-8") is read past.

==========================================================  =============  =========
written by                                                  channel names  times
==========================================================  =============  =========
``DataFrame(Y, index=names, columns=times).to_csv(path)``   first column   first row
``np.savetxt(path, Y, delimiter=",")``                      none           none
``...to_csv(path, index=False)``                            none           first row
``...to_csv(path, header=False)``                           first column   none
==========================================================  =============  =========
"""

import csv
import io
import itertools

import numpy as np

from .._utils.checks import InputError, check_array

__all__ = ["read_csv"]


_CSV_LAYOUT = (
    "expected channels in rows and times in columns: numbers only (np.savetxt), or with "
    "channel names in the first column and/or times in seconds in the first row, e.g. "
    "',-0.1,-0.099,...' then 'Fp1,1.2e-06,...' (DataFrame(Y, index=names, columns=times)"
    ".to_csv())"
)


def _number(text):
    try:
        return float(text)
    except ValueError:
        return None


def _times_like(values):
    """Sample times: at least 3, increasing by steps within 10% of each other."""
    steps = np.diff(values)
    return len(values) >= 3 and steps.min() > 0 and np.ptp(steps) <= 0.1 * np.median(steps)


def _csv_layout(rows, path):
    """Whether the first column holds names and the first row times: read off the content."""
    refuse = InputError(f"{path}: cannot tell its layout; {_CSV_LAYOUT}")
    first, body = rows[0], rows[1:3]
    names = [_number(row[0]) is None for row in body or [first]]
    if any(names) and not all(names):
        raise refuse
    names = names[0]
    labels = [_number(cell) for cell in first[int(names) :]]
    if not body:  # one row: a channel, never a header alone
        if None in labels:
            raise refuse
        return names, False
    if None in labels:  # a row of text over the columns: names, if the rows are named
        if not names:
            raise refuse  # channels in columns (times x channels)?
        return names, "text"
    if names and first[0].strip() == "":
        return names, True
    if _times_like(np.array(labels)):
        return names, True
    if len(labels) < 3 and not names and np.all(np.diff(labels) > 0):
        raise refuse  # two samples: times or data, nothing tells
    return names, False


def read_csv(path):
    """Data from a CSV file, its layout read off the content (module docstring).

    Parameters
    ----------
    path : Path

    Returns
    -------
    data : ndarray, shape (n_channels, n_times)
    ch_names : list of str or None
    times : ndarray, shape (n_times,) or None
        Seconds.
    """
    import pandas as pd

    try:
        text = path.read_text(encoding="utf-8-sig")  # a BOM (Excel's UTF-8) is not a name
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: cannot be read as CSV: {err}") from err
    head = list(itertools.islice(filter(None, csv.reader(io.StringIO(text))), 3))
    if not head:
        raise InputError(f"{path}: no data; {_CSV_LAYOUT}")
    names, header = _csv_layout(head, path)
    try:
        table = pd.read_csv(
            io.StringIO(text),
            header=None,
            skiprows=int(bool(header)),
            index_col=0 if names else None,
        )
        values = table.to_numpy(dtype=float)
    except ValueError as err:  # pandas' own, and a cell that is no number
        raise InputError(f"{path}: cannot be read as CSV ({_CSV_LAYOUT}): {err}") from err
    data = check_array(f"{path}", values, ("n_channels", "n_times"))
    times = None
    if header is True:
        times = np.array([float(cell) for cell in head[0][int(names) :]])
        if len(times) != data.shape[1]:
            raise InputError(
                f"{path}: {len(times)} times in the first row, {data.shape[1]} columns of data"
            )
    channel_names = [str(name).strip() for name in table.index] if names else None
    return data, channel_names, times
