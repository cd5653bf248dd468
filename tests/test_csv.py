"""CSV data in the layouts people write: read off the content on evidence, or refused saying
how to tell. Every writer (pandas, np.savetxt, Excel, R), every delimiter, row labels, times
rows rounded to the precision printed, and what could be either."""

import itertools

import numpy as np
import pandas as pd
import pytest

from skf_ref import InputError
from skf_ref.io import read_data

RNG = np.random.default_rng(0)
Y = RNG.standard_normal((8, 20))
NAMES = [f"E{i}" for i in range(8)]
SFREQ = 600.615  # an odd rate: times rounded to the millisecond step by 1 or 2 ms
TIMES = np.arange(20) / SFREQ - 0.01
MS_TIMES = np.round(TIMES, 3)
# np.savetxt's default format keeps 19 digits; "%.6g" keeps 6 (a relative 5e-7)
SIX_DIGITS = 5e-6

WRITERS = {
    # name: (write(path), names read, times read, digits kept)
    "pandas, names and times": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(p),
        NAMES,
        TIMES,
        0,
    ),
    "pandas, default index (row labels 0..7)": (
        lambda p: pd.DataFrame(Y).to_csv(p),
        None,
        None,
        0,
    ),
    "pandas, default index, no header": (
        lambda p: pd.DataFrame(Y).to_csv(p, header=False),
        None,
        None,
        0,
    ),
    "pandas, default index and times": (
        lambda p: pd.DataFrame(Y, columns=TIMES).to_csv(p),
        None,
        TIMES,
        0,
    ),
    "pandas, times rounded to the ms, no index": (
        lambda p: pd.DataFrame(Y, columns=MS_TIMES).to_csv(p, index=False),
        None,
        MS_TIMES,
        0,
    ),
    "pandas, names, no times": (
        lambda p: pd.DataFrame(Y, index=NAMES).to_csv(p, header=False),
        NAMES,
        None,
        0,
    ),
    "pandas, tab": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(p, sep="\t"),
        NAMES,
        TIMES,
        0,
    ),
    "pandas, space": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(p, sep=" "),
        NAMES,
        TIMES,
        0,
    ),
    "Excel in Europe (semicolons, decimal commas)": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=MS_TIMES).to_csv(p, sep=";", decimal=","),
        NAMES,
        MS_TIMES,
        0,
    ),
    "Excel UTF-8 (a byte-order mark)": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(p, encoding="utf-8-sig"),
        NAMES,
        TIMES,
        0,
    ),
    "R write.table (no corner cell)": (
        lambda p: pd.DataFrame(Y, index=NAMES, columns=MS_TIMES).to_csv(
            p, sep=" ", index_label=False
        ),
        NAMES,
        MS_TIMES,
        0,
    ),
    "np.savetxt, default (spaces)": (lambda p: np.savetxt(p, Y), None, None, 0),
    "np.savetxt, tab": (lambda p: np.savetxt(p, Y, delimiter="\t"), None, None, 0),
    "np.savetxt, semicolon": (lambda p: np.savetxt(p, Y, delimiter=";"), None, None, 0),
    "np.savetxt, comma": (lambda p: np.savetxt(p, Y, delimiter=","), None, None, 0),
    "np.savetxt, fixed width": (lambda p: np.savetxt(p, Y, fmt="%14.6g"), None, None, 6),
    "np.savetxt, with a header line": (
        lambda p: np.savetxt(p, Y, delimiter=",", header="my recording"),
        None,
        None,
        0,
    ),
    "np.savetxt, times row": (
        lambda p: np.savetxt(p, np.vstack([TIMES, Y]), delimiter=","),
        None,
        TIMES,
        0,
    ),
    "channels numbered 1..8": (
        lambda p: np.savetxt(p, np.column_stack([np.arange(1, 9), Y]), fmt="%d" + ",%.6g" * 20),
        None,
        None,
        6,
    ),
}


@pytest.mark.parametrize("writer", WRITERS, ids=list(WRITERS))
def test_every_writer_s_layout_is_read_off_the_content(tmp_path, writer):
    write, names, times, digits = WRITERS[writer]
    path = tmp_path / "y.csv"
    write(path)
    read = read_data(path)
    rtol = SIX_DIGITS if digits else 1e-15
    assert read.data.shape == Y.shape  # no row label read as a sample, no channel lost
    np.testing.assert_allclose(read.data, Y, rtol=rtol, atol=rtol)
    assert read.ch_names == names
    if times is None:
        assert read.times is None
    else:
        np.testing.assert_allclose(read.times, times, rtol=1e-15, atol=1e-18)


def test_times_rounded_to_the_millisecond_are_times_and_steps_were_uneven(tmp_path):
    steps = np.diff(MS_TIMES)
    assert steps.max() / steps.min() > 1.9  # 1 and 2 ms: not "equal within 10 %"
    path = tmp_path / "y.csv"
    np.savetxt(path, np.vstack([MS_TIMES, Y]), fmt="%.3f", delimiter=",")
    read = read_data(path)
    np.testing.assert_array_equal(read.times, MS_TIMES)
    assert read.data.shape == Y.shape


@pytest.mark.parametrize("n_times", [3, 200, 5000])
def test_rounded_times_at_any_length_and_precision(tmp_path, n_times):
    rng = np.random.default_rng(n_times)
    data = rng.standard_normal((4, n_times))
    for decimals, fmt in itertools.product((3, 4, 6), ("f", "e")):
        times = np.arange(n_times) / SFREQ + 0.1234
        text = ",".join(f"{t:.{decimals}{fmt}}" for t in times)
        path = tmp_path / "y.csv"
        path.write_text(text + "\n" + "\n".join(",".join(map(str, row.tolist())) for row in data))
        read = read_data(path)
        assert read.times is not None and read.data.shape == data.shape, (decimals, fmt)


def _drifting(seed, n=20, drift=1e-6, noise=1e-8):
    """A channel rising steadily with noise above the precision printed: never times."""
    rng = np.random.default_rng(seed)
    return 1e-5 + drift * np.arange(n) + noise * rng.standard_normal(n)


@pytest.mark.parametrize("seed", range(5))
def test_a_drifting_first_channel_is_never_taken_for_times(tmp_path, seed):
    path = tmp_path / "y.csv"
    np.savetxt(path, np.vstack([_drifting(seed), Y]), delimiter=",")
    with pytest.raises(InputError, match=r"y.csv: its first row increases steadily .* say which"):
        read_data(path)
    # named, it is a channel: the rows' names say so
    frame = pd.DataFrame(np.vstack([_drifting(seed), Y]), index=["drift", *NAMES])
    frame.to_csv(path, header=False)
    read = read_data(path)
    assert read.data.shape == (9, 20) and read.ch_names[0] == "drift" and read.times is None


def test_the_sampling_rate_tells_times_from_a_channel(tmp_path):
    path = tmp_path / "y.csv"
    jittered = TIMES + np.random.default_rng(1).uniform(-2e-4, 2e-4, TIMES.size)
    np.savetxt(path, np.vstack([jittered, Y]), delimiter=",")
    with pytest.raises(InputError, match="say which"):
        read_data(path)
    assert read_data(path, sfreq=SFREQ).data.shape == (9, 20)  # not 1/sfreq steps: a channel
    np.savetxt(path, np.vstack([TIMES, Y]), delimiter=",")
    assert read_data(path, sfreq=SFREQ).times is not None
    assert read_data(path, sfreq=2 * SFREQ).data.shape == (9, 20)
    pd.DataFrame(Y, index=NAMES, columns=TIMES).to_csv(path)  # labelled times, other rate
    with pytest.raises(InputError, match=r"do not step by 1/sfreq = .* give the sampling rate"):
        read_data(path, sfreq=2 * SFREQ)
    with pytest.raises(InputError, match="sfreq must be > 0"):
        read_data(path, sfreq=-1.0)


@pytest.mark.parametrize(
    "content, match",
    [
        # row labels on too few rows to tell, or written with a decimal point
        ("0,1.5,2.5,3.5\n1,3.5,4.5,7.5\n", r"its first column is 0, 1: row numbers, or"),
        ("0,1.5,2.5\n", r"its first column is 0: row numbers"),
        ("0.0,1.5,2.5\n1.0,3.5,4.5\n2.0,5.1,1.2\n", r"its first column is 0.0, 1.0, 2.0"),
        # a row like sample times named like a channel ("time (ms)" is no label of seconds)
        ("Fp1,1,2,3,4\nCz,5,3,1,2\n", r"its first row, named 'Fp1', steps evenly"),
        ("time (ms),1,2,3,4\nCz,5,3,1,2\n", r"named 'time \(ms\)', steps evenly"),
        # two increasing samples: times or a channel
        ("0.0,0.1\n1.0,2.0\n3.0,4.0\n", r"a first row of two increasing numbers"),
        # a header whose numbers are no times
        (",0.3,0.2,0.1\nA,1,2,3\nB,4,5,6\n", r"first row is a header .* do not increase"),
        # layouts of another shape: channels in columns, rows named and not
        ("Fp1,Fp2,Cz\n1.0,2.0,3.0\n4.0,5.0,6.0\n", r"cannot tell its layout; expected channels"),
        (",0.0,0.1,0.2\nE1,1,2,3\n4,5,6,7\n", r"data row 2 is named and data row 3 is not"),
        ("Fp1,1,2,3\n4,5,6,7\n", r"cannot tell its layout"),
        # damage
        ("1,2,3\n4,5\n", r"line 1 has 3 cells and line 2 has 2"),
        ("1,2,3\n4,5,6\n7,8\n", r"line 3 has 2 cells and line 2 has 3"),
        ("1,2,3\n4,five,6\n", r"could not convert string 'five'"),
        ("A\nB\n", r"no samples, only a column of names"),
        ("", r"no data; expected channels in rows"),
        ("# only a comment\n", r"no data"),
    ],
)
def test_what_cannot_be_told_is_refused_saying_how(tmp_path, content, match):
    path = tmp_path / "x.csv"
    path.write_text(content)
    with pytest.raises(InputError, match=match) as info:
        read_data(path)
    assert str(path) in str(info.value)
    if "row numbers" in match or "steps evenly" in match or "two increasing" in match:
        assert "say which" in str(info.value).lower()


@pytest.mark.parametrize(
    "content, twice",
    [
        ("E1,1,2\nE2,3,4\nE1,5,6\n", "E1"),
        (",0.0,0.001\nE1,1,2\n E1 ,3,4\n", "E1"),  # spaces around a name are no name
        ("Cz\t1\t2\nCz\t3\t4\n", "Cz"),
    ],
)
def test_a_channel_named_twice_is_refused(tmp_path, content, twice):
    path = tmp_path / "x.csv"
    path.write_text(content)
    with pytest.raises(InputError, match=rf"first column \(channel names\) holds '{twice}' twice"):
        read_data(path)


def test_numbered_rows_under_a_corner_cell_are_names_or_row_numbers(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text(",0.0,0.001,0.002\n3,1,2,3\n7,4,5,6\n12,7,8,9\n")  # channels 3, 7, 12
    assert read_data(path).ch_names == ["3", "7", "12"]
    path.write_text(",0.0,0.001,0.002\n0,1,2,3\n1,4,5,6\n")  # pandas' index: row numbers
    read = read_data(path)
    assert read.ch_names is None and read.data.shape == (2, 3)
    path.write_text(",0,1,2\nA,1,2,3\nB,4,5,6\n")  # pandas' default columns: no times
    assert read_data(path).times is None


def test_quoted_names_with_delimiters_inside(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text('"",0.0,0.001,0.002\n"E 1",1,2,3\n"E,2",4,5,1\n')
    read = read_data(path)
    assert read.ch_names == ["E 1", "E,2"]
    np.testing.assert_array_equal(read.data, [[1, 2, 3], [4, 5, 1]])


def test_one_channel_and_one_sample(tmp_path):
    path = tmp_path / "x.csv"
    np.savetxt(path, Y[:1], delimiter=",")
    assert read_data(path).data.shape == (1, 20)
    np.savetxt(path, Y[:, :1])
    assert read_data(path).data.shape == (8, 1)


def test_a_single_named_row_is_a_channel_whatever_its_numbers(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("Fp1,1,2,3,4\n")  # no data row under it: a header over nothing is none
    read = read_data(path)
    assert read.ch_names == ["Fp1"] and read.times is None
    np.testing.assert_array_equal(read.data, [[1, 2, 3, 4]])
