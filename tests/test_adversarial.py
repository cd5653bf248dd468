"""Adversarial input: every case ends in a clear error or a verified result, never in silence.

The classes of input: non-finite, overflowing, empty, wrongly typed, masked, out of range,
ill-conditioned, damaged results files, a concurrent writer, too large, and interruptions
(SIGKILL, Ctrl-C) at the command line. At the API an error is an ``skf_ref.InputError``
(or ``MemoryError``) whose message names the parameter; at the command line it is one line
on stderr, exit status 2, and no output file left behind.
"""

import os
import re
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from processes import ctrl_c, start, wait_for_line

import skf_ref
from skf_ref import InputError, InputTypeError, reconstruct
from skf_ref._utils.atomic_files import atomic_path
from skf_ref.study._sweep import read_results, run_sweep

ROOT = Path(__file__).resolve().parents[1]
ENV = os.environ | {"PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
PATHS = ("spectral", "dense", "filterpy")
# Two paths on a well-conditioned model (condition numbers below 1e3) differ by rounding.
CROSS_PATH_RTOL = 1e-10


def _model(m=6, n=8, T=5, seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((m, n)), rng.standard_normal((m, T))


def _run(method="spectral", **change):
    L, Y = _model()
    kwargs = dict(noise_std=0.1, theta0=1.0, q=0.1, path=method) | change
    rec = reconstruct(kwargs.pop("L", L), kwargs.pop("Y", Y), **kwargs)
    return rec, rec.z, rec.weights  # every output computed


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


# --- silent wrong output ------------------------------------------------------------------


@pytest.mark.parametrize(
    "a, n_times", [(2.0, 600), pytest.param(1.05, 10_000, marks=pytest.mark.slow)]
)
@pytest.mark.parametrize("smoother", ["rts-standardized", "rts-state"])
def test_a_growing_transition_stays_finite_and_equals_dense(a, n_times, smoother):
    # q / c, not c, enters the smoother: c grows as a^(2t) past the largest double
    rng = np.random.default_rng(0)
    L, Y = rng.standard_normal((6, 3)), rng.standard_normal((6, n_times))
    kwargs = dict(noise_std=0.1, theta0=1.0, q=0.1, transition=a, smoother=smoother)
    spectral, dense = reconstruct(L, Y, **kwargs), reconstruct(L, Y, **kwargs, path="dense")
    assert spectral.path == "spectral"
    for name in ("z", "x", "weights"):
        assert relative(getattr(spectral, name), getattr(dense, name)) < CROSS_PATH_RTOL, name


@pytest.mark.parametrize("method", PATHS)
@pytest.mark.parametrize(
    "change, match",
    [
        ({"exponent": 1e6}, r"exponent=1e\+06 is too large .* overflows above exponent"),
        ({"L": _model()[0] * 1e-200}, "lead field is too weak against the noise"),
        ({"Y": _model()[1] * 1e200}, "Y is out of range for the noise"),
    ],
    ids=["exponent 1e6", "L x 1e-200", "Y x 1e200"],
)
def test_outputs_that_would_overflow_raise_with_the_cause(method, change, match):
    with pytest.raises(InputError, match=match):
        _run(method, **change)


def test_the_largest_exponent_named_works():
    _, _, weights = _run(exponent=1.0)
    w_min = 1 / np.max(weights)  # the smallest raw weight: weights = w^-1
    limit = np.log(np.finfo(float).max) / -np.log(w_min)
    assert np.isfinite(_run(exponent=0.9 * limit)[2]).all()
    with pytest.raises(InputError, match=re.escape(f"overflows above exponent {limit:.3g}")):
        _run(exponent=1.01 * limit)


@pytest.mark.parametrize("scale", [1e200, 1e-200, 1.0])
@pytest.mark.parametrize("convention", ["gain", "toolbox"])
def test_lead_field_amplitude_at_any_scale(scale, convention):
    L = _model()[0]
    amplitude = skf_ref.lead_field_amplitude(L * scale, convention)
    unit = skf_ref.lead_field_amplitude(L, convention)
    power = 1.0 if convention == "gain" else 0.5  # 1/||L|| and ||L||^-1/2
    assert amplitude == pytest.approx(unit / scale**power, rel=1e-14)


@pytest.mark.parametrize("name", ["L", "Y", "noise_cov"])
def test_masked_arrays_are_refused(name):
    L, Y = _model()
    value = {"L": L, "Y": Y, "noise_cov": np.eye(6)}[name]
    masked = np.ma.masked_array(value, mask=np.zeros(value.shape, bool))
    kwargs = dict(L=L, Y=Y, noise_std=0.1) | {name: masked}
    if name == "noise_cov":
        del kwargs["noise_std"]
    with pytest.raises(InputTypeError, match=f"{name} must be a plain array, got a masked"):
        reconstruct(kwargs.pop("L"), kwargs.pop("Y"), theta0=1.0, q=0.1, **kwargs)


def _mp_reference(L, Y, sigma, theta0, q, exponent):
    """The filter of docs/model.md §2 in 60-digit arithmetic: z and weights (n, T)."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 60
    m, n = L.shape
    Lm, R = mp.matrix(L.tolist()), sigma**2 * mp.eye(m)
    P, x, zs, ws = theta0 * mp.eye(n), mp.zeros(n, 1), [], []
    for t in range(Y.shape[1]):
        P_pred = P + q * mp.eye(n)
        S = Lm * P_pred * Lm.T + R
        K = P_pred * Lm.T * mp.inverse(S)
        x = x + K * (mp.matrix(Y[:, t].tolist()) - Lm * x)
        P = P_pred - K * S * K.T
        E, Q = mp.eigsy(P_pred)
        inv_sqrt = Q * mp.diag([1 / mp.sqrt(e) for e in E]) * Q.T
        M, whitened = inv_sqrt * K * S * K.T * inv_sqrt, inv_sqrt * x
        weights = [M[i, i] ** (-exponent) for i in range(n)]
        ws.append([float(w) for w in weights])
        zs.append([float(w * whitened[i]) for i, w in enumerate(weights)])
    return np.array(zs).T, np.array(ws).T


@pytest.mark.parametrize("c", [1e-4, 1e-8, 1e-12])
def test_spectral_accuracy_with_lead_field_columns_of_very_different_size(c):
    # one column c times the others: the SVD alone gives its row of V to eps / c relative;
    # rows of weak columns come from L~^T U / s instead (docs/model.md §2), and every
    # column's z and weights hold to rounding against a 60-digit reference
    L, Y = _model(6, 9, 3)
    L[:, 2] *= c
    z_ref, w_ref = _mp_reference(L, Y, 0.5, 1.0, 0.1, 0.5)
    rec = reconstruct(L, Y, noise_std=0.5, theta0=1.0, q=0.1, path="spectral")
    per_column = np.max(np.abs(rec.z - z_ref), axis=1) / np.max(np.abs(z_ref), axis=1)
    assert per_column.max() < 1e-12
    per_column = np.max(np.abs(rec.weights - w_ref), axis=1) / np.max(np.abs(w_ref), axis=1)
    assert per_column.max() < 1e-12


# --- out of range, empty, ill-conditioned ---------------------------------------------------


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda L: skf_ref.priors_from_snr(L, 0.1, 3100, 20, 5), InputError, "pm_snr_db must"),
        (lambda L: skf_ref.priors_from_snr(L, 0.1, -4000, 20, 5), InputError, ">= -300 dB"),
        (lambda L: skf_ref.priors_from_snr(L, 0.1, 0, 4000, 5), InputError, "ep_snr_db must"),
        (lambda L: skf_ref.priors_from_snr(L * 1e-200, 0.1, 0, 20, 5), InputError, "theta0 ="),
        (
            lambda L: skf_ref.priors_from_snr(L[:, :0], 0.1, 0, 20, 5),
            InputError,
            r"L must have at least one channel and one source, got shape \(6, 0\)",
        ),
        (lambda L: skf_ref.evolution_variance(20, 1e-320, 5), InputError, "q = 10"),
        (lambda L: skf_ref.priors_from_snr(L, "0.1", 0, 20, 5), InputTypeError, "noise_std"),
    ],
    ids=["PM 3100", "PM -4000", "EP 4000", "L tiny", "L empty", "q underflows", "sigma str"],
)
def test_priors_out_of_range(call, error, match):
    with pytest.raises(error, match=match):
        call(_model()[0])


@pytest.mark.parametrize("method", PATHS)
@pytest.mark.parametrize(
    "change, match",
    [
        ({"noise_std": 1e200}, r"noise_std must be within \[1.49e-154, 1.34e\+154\]"),
        ({"noise_std": 1e-170}, r"noise_std must be within"),
        ({"transition": 1e200}, "transition, theta0 and q are out of range"),
        ({"L": np.empty((6, 0))}, "L must have at least one channel and one source"),
        ({"Y": np.empty((6, 0))}, "Y must have at least one time step"),
        ({"exponent": "1"}, r"exponent must be a real number, got '1' \(str\)"),
    ],
    ids=["sigma 1e200", "sigma 1e-170", "transition 1e200", "L empty", "Y empty", "exp str"],
)
def test_every_path_refuses_the_same_inputs(method, change, match):
    with pytest.raises(InputError, match=match):
        _run(method, **change)


@pytest.mark.parametrize("method", ["dense", "filterpy"])
def test_ill_conditioned_covariances_say_what_failed(method):
    # transition 2 over 60 steps with more sources than channels: the unobserved part of
    # P_t|t-1 grows as 4^t; the dense paths lose positive definiteness in double precision
    rng = np.random.default_rng(0)
    L, Y = rng.standard_normal((4, 8)), rng.standard_normal((4, 60))
    kwargs = dict(noise_std=0.1, theta0=1.0, q=0.1, transition=2.0)
    with pytest.raises(InputError, match=r"failed at step \d+: .*eigenvalues from .*spectral"):
        reconstruct(L, Y, **kwargs, path=method)
    assert np.isfinite(reconstruct(L, Y, **kwargs, smoother="rts-standardized").z).all()


def test_spectral_outputs_that_do_not_fit_are_refused_before_any_work():
    # the model fits; an output in memory would not, so asking for it is refused (naming
    # the way to stream it) before anything is allocated, and a block of it still comes
    L = np.eye(4, 100_000) + 1.0
    rec = reconstruct(L, np.zeros((4, 20_000)), noise_std=1, theta0=1, q=1, memory_limit=2**30)
    with pytest.raises(MemoryError, match=r"a \(100000, 20000\) output array .* needs 14.9 GiB"):
        _ = rec.z
    with pytest.raises(MemoryError, match=r"stream it instead: skf_ref.io.to_zarr"):
        _ = rec.weights
    columns, block = next(iter(rec.blocks("z", rows=10)))
    assert block.shape == (10, 20_000)
    model_too_large = dict(noise_std=1, theta0=1, q=1, memory_limit=2**20)
    with pytest.raises(MemoryError, match=r"needs about 0.0\d+ GiB for its model"):
        reconstruct(L, np.zeros((4, 20_000)), **model_too_large)


def test_sweep_arguments_are_checked(tmp_path):
    grid = dict(
        snr_db=[20.0], ep_snr_db=[0.0], pm_snr_db=[0.0], exponent=[0.5], smoother=[None], seed=[0]
    )
    for runs_per_task in (0, -1):
        with pytest.raises(InputError, match=f"runs_per_task must be >= 1, got {runs_per_task}"):
            run_sweep(grid, tmp_path / "r.csv", runs_per_task=runs_per_task, verbose=False)
    with pytest.raises(InputError, match="pm_snr_db'] values must be <= 300 dB"):
        run_sweep(grid | {"pm_snr_db": [4000.0]}, tmp_path / "r.csv", verbose=False)
    assert not any(tmp_path.iterdir())


# --- damaged results files ----------------------------------------------------------------

HEADER = "n_positions,montage,snr_db,ep_snr_db,pm_snr_db,exponent,smoother,seed,deep_error_mm\n"
ROW = "480,biosemi64,20.0,0.0,0.0,0.5,none,{seed},12.5\n"


@pytest.mark.parametrize(
    "content, match",
    [
        (b"a,b\n1,2\n", r"is not a results file of skf-ref sweep: .*\['n_positions'"),
        pytest.param(
            b"\x89PNG\r\n\x1a\n\xff\xfe\x00garbage\n",
            "is not a results file: byte 0 is not UTF-8",
            marks=pytest.mark.slow,
        ),
        pytest.param(
            HEADER + ROW.format(seed="twenty"),
            "line 2: a key column is not a number",
            marks=pytest.mark.slow,
        ),
        pytest.param(
            HEADER + ROW.format(seed=0) + "480,biosemi64,20.0\n",
            "line 3: 3 fields, expected 9",
            marks=pytest.mark.slow,
        ),
        pytest.param(
            HEADER + ROW.format(seed=""), "line 2: 'seed' is empty", marks=pytest.mark.slow
        ),
        pytest.param(
            HEADER + ROW.format(seed=0) * 2,
            "line 3 repeats the run of line 2",
            marks=pytest.mark.slow,
        ),
    ],
    ids=["other columns", "binary", "key not a number", "missing fields", "empty", "twice"],
)
def test_damaged_results_files_are_refused_naming_file_and_line(tmp_path, content, match):
    out = tmp_path / "results.csv"
    out.write_bytes(content.encode() if isinstance(content, str) else content)
    before = out.read_bytes()
    with pytest.raises(InputError, match=match) as info:
        read_results(out)
    assert str(out) in str(info.value)
    result = _cli("sweep", "--out", str(out), "--seeds", "1", "--positions", "500", "--quiet")
    assert result.returncode == 2 and match.split(":")[0].split(r"\[")[0] in result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert out.read_bytes() == before  # never repaired silently


@pytest.mark.slow
def test_a_second_sweep_on_the_same_file_is_refused(tmp_path):
    from filelock import FileLock

    out = tmp_path / "results.csv"
    with FileLock(tmp_path / ".results.csv.lock"):  # a first sweep holds the file
        result = _cli("sweep", "--out", str(out), "--seeds", "1", "--positions", "500")
    assert result.returncode == 2
    assert "is in use by another sweep" in result.stderr and result.stderr.count("\n") == 1
    assert not out.exists()


# --- the command line ---------------------------------------------------------------------


def _cli(*arguments, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "skf_ref.cli", *arguments],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=timeout,
    )


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["demo", "--pm-snr-db", "4000"], "argument --pm-snr-db: must be within +-300 dB"),
        (["demo", "--ep-snr-db", "4000"], "argument --ep-snr-db: must be within +-300 dB"),
        (["demo", "--snr-db", "-7000"], "argument --snr-db: must be within +-300 dB"),
        (["demo", "--snr-db", "-inf"], "argument --snr-db: must be finite, got -inf"),
        (["demo", "--seed", "-1"], "argument --seed: must be >= 0"),
        (["demo", "--exponent", "1e6"], "exponent=1e+06 is too large"),
        (
            ["demo", "--source-space", "volume", "--positions", "2000000"],
            "--positions: n_positions 2000000 needs",
        ),
        (["sweep", "--pm-snr-db", "4000"], "argument --pm-snr-db: must be within +-300 dB"),
        (["sweep", "--positions", "4000000"], "--positions 4000000"),
    ],
)
def test_command_line_errors_are_one_line_with_no_file_left(cli, tmp_path, arguments, message):
    out = tmp_path / ("out.csv" if arguments[0] == "sweep" else "demo")
    result = cli(*arguments, "--out", str(out), "--quiet")
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not result.warnings, [str(w.message) for w in result.warnings]
    assert message in result.stderr
    assert not out.exists() or not any(out.iterdir())


_INTERRUPTED = "skf-ref: interrupted; files already written are complete\n"

# A child that stops inside an import of scipy, once it has said so: the interruption lands
# while the command line loads numpy, scipy and MNE.
_STARTING = textwrap.dedent(
    """
    import importlib.abc, sys, time

    class Announce(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "scipy":
                print("importing scipy", flush=True)
                time.sleep(600)  # until interrupted
            return None

    sys.meta_path.insert(0, Announce())
    from skf_ref.cli import console
    sys.argv = ["skf-ref", *sys.argv[1:]]
    console()
    """
)


def test_ctrl_c_while_starting_ends_with_one_line_and_130(tmp_path):
    process = start(_STARTING, "demo", "--out", tmp_path / "d")
    wait_for_line(process, "importing scipy")
    status, _, err = ctrl_c(process)
    assert (status, err) == (130, _INTERRUPTED)
    assert not (tmp_path / "d").exists()


# The command winds down: an exit handler registered by the work (joblib's waits for its
# workers) runs long, and says so first.
_WINDING_DOWN = textwrap.dedent(
    """
    import atexit, sys, time
    import skf_ref.cli as cli

    command = cli.main

    def main(argv=None):
        status = command(argv)
        atexit.register(lambda: (print("winding down", flush=True), time.sleep(600)))
        return status

    cli.main = main
    sys.argv = ["skf-ref", *sys.argv[1:]]
    cli.console()
    """
)


def _arrays(folder):
    rng = np.random.default_rng(0)
    L = rng.standard_normal((8, 20))
    np.save(folder / "L.npy", L)
    np.save(folder / "Y.npy", L @ rng.standard_normal((20, 5)))
    return ["reconstruct", "--leadfield", folder / "L.npy", "--data", folder / "Y.npy",
            "--noise-std", "1", "--out", folder / "o.npz"]  # fmt: skip


@pytest.mark.slow
def test_ctrl_c_while_the_command_winds_down_ends_with_one_line_and_130(tmp_path):
    process = start(_WINDING_DOWN, *_arrays(tmp_path), "--quiet")
    wait_for_line(process, "winding down")
    status, _, err = ctrl_c(process)
    assert (status, err) == (130, _INTERRUPTED)
    assert np.load(tmp_path / "o.npz")["z"].shape == (20, 5)  # written whole before


# Interrupted while the estimate is being written: the writer says where, then waits.
_WRITING = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from skf_ref.cli import console

    def slow_writer(file, *args, **kwargs):
        print("writing", file, flush=True)
        time.sleep(600)

    np.savez_compressed = slow_writer
    sys.argv = ["skf-ref", *sys.argv[1:]]
    console()
    """
)


def test_ctrl_c_while_writing_ends_with_one_line_130_and_no_file(tmp_path):
    process = start(_WRITING, *_arrays(tmp_path), "--plot", tmp_path / "o.png")
    (line,) = wait_for_line(process, "writing")
    temporary = Path(line.split(" ", 1)[1])
    assert temporary.name.startswith(".o.skf-tmp-") and temporary.exists()
    status, _, err = ctrl_c(process)
    said = "standardized column by column (--standardize column, the default on arrays)\n"
    assert (status, err) == (130, said + _INTERRUPTED)  # what was said before, then one line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["L.npy", "Y.npy"]  # nothing half


# An interruption that Python swallows on its way: a KeyboardInterrupt raised inside a
# finalizer is only printed ("Exception ignored in ..."), and the command goes on.
_IN_A_FINALIZER = textwrap.dedent(
    """
    import sys, time
    import skf_ref.cli._reconstruct as command
    from skf_ref.cli import console

    class Slow:
        def __del__(self):
            print("finalizing", flush=True)
            time.sleep(600)

    write = command._write

    def _write(*args):
        written = write(*args)
        Slow()  # finalized at once
        return written

    command._write = _write
    sys.argv = ["skf-ref", *sys.argv[1:]]
    console()
    """
)


@pytest.mark.slow
def test_an_interruption_swallowed_on_its_way_still_ends_with_130(tmp_path):
    process = start(_IN_A_FINALIZER, *_arrays(tmp_path), "--quiet")
    wait_for_line(process, "finalizing")
    status, _, err = ctrl_c(process)
    assert (status, err) == (130, _INTERRUPTED)  # no "Exception ignored", no exit 0
    assert np.load(tmp_path / "o.npz")["z"].shape == (20, 5)


@pytest.mark.slow  # a sweep on two workers until rows are written: 20-30 s
def test_killed_sweep_leaves_no_worker_running(tmp_path):
    out = tmp_path / "r.csv"
    command = [sys.executable, "-m", "skf_ref.cli", "sweep", "--out", str(out), "--jobs", "2"]
    process = subprocess.Popen(
        [*command, "--positions", "500", "--seeds", "100", "--quiet"], env=ENV
    )
    deadline = time.monotonic() + 120
    while (not out.exists() or out.read_bytes().count(b"\n") < 20) and time.monotonic() < deadline:
        time.sleep(0.05)
    children = Path(f"/proc/{process.pid}/task/{process.pid}/children").read_text().split()
    workers = [int(pid) for pid in children if "Loky" in _cmdline(pid)]
    assert len(workers) == 2
    process.kill()
    process.wait()
    deadline = time.monotonic() + 30
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers)


def _cmdline(pid):
    try:
        return Path(f"/proc/{pid}/cmdline").read_text()
    except OSError:
        return ""


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"  # a zombie has exited


def test_temporaries_of_a_killed_writer_are_removed_by_the_next_one(tmp_path):
    target = tmp_path / "figure.png"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".figure.skf-tmp-{dead.pid}-abc123.png"
    stale.write_bytes(b"half a figure")
    live = tmp_path / f".figure.skf-tmp-{os.getpid()}-def456.png"  # a writer still running
    live.write_bytes(b"in progress")
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"whole")
    assert not stale.exists() and live.exists() and target.read_bytes() == b"whole"
