"""Argument parsing for ``skf-ref``: one-line errors naming the flag, defaults in the help."""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from typing import Any, NoReturn

from .._utils.checks import MAX_DB, InputError, check_int, check_real

__all__ = [
    "Parser",
    "add_skf_options",
    "db",
    "integer",
    "milliseconds",
    "nonnegative",
    "positive",
    "report_tuning",
]

# Negative numbers, infinities and NaN are values, not options: "--snr-db -inf" parses, and so
# does a range of them, "--pm-snr-db -40,20".
_REAL = r"[-+]?((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|inf|infinity|nan)"
_NUMBER = re.compile(
    rf"^-((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|inf|infinity|nan)(,{_REAL})?$", re.IGNORECASE
)


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows every default except those that mean "not given" (None, False); keeps the
    line breaks of texts that have them (examples), wraps the others."""

    def _fill_text(self, text, width, indent):
        if "\n" in text:
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.required:
            return action.help
        return super()._get_help_string(action)


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are :class:`~skf_ref.InputError` (one line, exit 2)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _Formatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NUMBER

    def error(self, message: str) -> NoReturn:
        raise InputError(message)


def _number(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _typed(check):
    """An argparse type from a check: its error becomes "argument --flag: ..."."""

    def parse(text):
        try:
            return check(text)
        except InputError as err:
            message = str(err).split(" ", 1)[1]  # drop the parameter name: argparse adds the flag
            raise argparse.ArgumentTypeError(f"{message}") from None

    parse.__name__ = check.__name__
    return parse


def db(maximum: float = MAX_DB, auto: bool = False) -> Callable[[str], Any]:
    """A level in dB: finite, within +-``maximum`` (10**(dB/10) far from overflow).

    With ``auto``, priors the data choose are accepted too: the word "auto" (the default
    range) or a range ``LOW,HIGH`` in dB to search, e.g. ``-40,20`` (a tuple).

    Examples
    --------
    >>> parse = db(auto=True)
    >>> parse("-3"), parse("auto"), parse("-40,20")
    (-3.0, 'auto', (-40.0, 20.0))
    """

    def number(text):
        value = check_real("value", _number(text))
        if abs(value) > maximum:
            raise InputError(f"value must be within +-{maximum:g} dB, got {text}")
        return value

    def level(text):
        if auto and text == "auto":
            return text
        if auto and "," in text:
            parts = text.split(",")
            if len(parts) != 2:
                raise InputError(f"value must be one number, auto or LOW,HIGH, got {text!r}")
            low, high = (number(part.strip()) for part in parts)
            if not low < high:
                raise InputError(f"value must be a range LOW,HIGH with LOW < HIGH, got {text!r}")
            return (low, high)
        return number(text)

    return _typed(level)


def milliseconds() -> Callable[[str], Any]:
    """A time constant in ms (> 0), or "auto", or a range ``LOW,HIGH`` in ms to search.

    Examples
    --------
    >>> parse = milliseconds()
    >>> parse("20"), parse("auto"), parse("2,200")
    (20.0, 'auto', (2.0, 200.0))
    """
    from ..method._search import check_time_constant

    def time_constant(text):
        if text == "auto":
            return text
        parts = [_number(part.strip()) for part in text.split(",")]
        if len(parts) > 2:
            raise InputError(f"value must be one number, auto or LOW,HIGH, got {text!r}")
        return check_time_constant(parts[0] if len(parts) == 1 else parts, "value")

    return _typed(time_constant)


def nonnegative(maximum: float | None = None) -> Callable[[str], float]:
    """A finite number >= 0 (and <= ``maximum``)."""
    return _typed(
        lambda text: check_real("value", _number(text), nonnegative=True, maximum=maximum)
    )


def positive() -> Callable[[str], float]:
    """A finite number > 0."""
    return _typed(lambda text: check_real("value", _number(text), positive=True))


def integer(minimum: int | None = None, maximum: int | None = None) -> Callable[[str], int]:
    """An integer in [minimum, maximum]."""

    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise InputError(f"value must be an integer, got {text!r}") from None
        return check_int("value", value, minimum=minimum, maximum=maximum)

    return _typed(parse)


def report_tuning(args: argparse.Namespace, tuning: Any) -> None:
    """Print the priors the data chose, and put them in ``args`` (for titles, settings);
    what was asked for (``"auto"``, a range) goes to ``args.searched``."""
    import sys

    if tuning is None:
        return
    args.searched = {"pm_snr_db": args.pm_snr_db, "ep_snr_db": args.ep_snr_db}
    args.pm_snr_db, args.ep_snr_db = tuning.pm_snr_db, tuning.ep_snr_db
    if tuning.time_constant_ms is None:
        evolution = f"EP-SNR {tuning.ep_snr_db:.2f} dB"
    else:  # the AR(1) prior (skf-ref reconstruct --time-constant-ms)
        args.searched["time_constant_ms"] = args.time_constant_ms
        args.time_constant_ms = tuning.time_constant_ms
        evolution = f"time constant {tuning.time_constant_ms:.3g} ms"
    args.tuned = True
    if getattr(args, "quiet", False):  # the settings file records the choice
        return
    print(
        f"priors chosen by the data: PM-SNR {tuning.pm_snr_db:.2f} dB, {evolution} "
        f"(log-likelihood {tuning.log_likelihood:.6g})",
        file=sys.stderr,
    )


def add_skf_options(
    parser: Any, *, exponent: Any, smoother: Any, smoother_help: str, time_constant: bool = False
) -> None:
    """The SKF's options, shared by the commands that run one: priors, exponent, smoother;
    with ``time_constant``, ``--time-constant-ms`` (the AR(1) prior) beside ``--ep-snr-db``."""
    chosen = "; or chosen by the data: auto (searched in -20..40 dB) or LOW,HIGH (e.g. -40,20)"
    parser.add_argument(
        "--pm-snr-db",
        type=db(auto=True),
        default=0.0,
        metavar="DB",
        help=f"PM-SNR prior (dB{chosen})",
    )
    parser.add_argument(
        "--ep-snr-db",
        type=db(auto=True),
        default=None if time_constant else 0.0,
        metavar="DB",
        help=f"EP-SNR prior of the paper's random walk (dB{chosen})"
        + ("; default 0 dB, unless --time-constant-ms is given" if time_constant else ""),
    )
    if time_constant:
        parser.add_argument(
            "--time-constant-ms",
            type=milliseconds(),
            metavar="MS",
            help="instead of the random walk, the stationary AR(1) prior: the sources' time "
            "constant in ms (rho = exp(-dt / tau), q = (1 - rho^2) theta0); or chosen by the "
            "data: auto (searched in 1..1000 ms) or LOW,HIGH (e.g. 2,200). Not with "
            "--ep-snr-db",
        )
    parser.add_argument(
        "--exponent", type=nonnegative(), default=exponent, help="standardization exponent alpha"
    )
    parser.add_argument(
        "--smoother",
        default=smoother,
        choices=("none", "rts-standardized", "rts-state", "rts-smoothed-weights"),
        help=smoother_help,
    )
