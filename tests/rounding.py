"""What rounding allows when a result is computed twice or printed (shared by the tests).

OpenBLAS chooses its kernels for the processor it runs on (threadpoolctl names the choice:
Haswell, SkylakeX, Sandybridge, ...), numpy dispatches its loops by instruction set and by
memory layout, and a product's blocking follows the arrays' shapes. The same algebra computed
along two routes (an epoch alone or stacked with the others, a raw recording or a segment cut
from it, an operator prepared once or in the call) therefore sums in other orders on another
machine, and the two results differ by rounding: a few ulps of each sum, times the condition
of the problem. Tests hold such pairs to :data:`ROUTE_RTOL`, relative to the larger result.

Bit-for-bit equality is asserted only where it holds by construction: the same function on
equal arrays of the same shape and layout (a file read back, a rerun, a copy, a value the
code assigns rather than computes), and the test says why.

Printed numbers carry the digits their format keeps; a value that sits on a rounding boundary
prints as either neighbour on different kernels (-4611.595... as -4611.6 or -4611.59).
:func:`same_printout` and :class:`NumberChecker` accept such a pair: the text must be equal,
and each number with a decimal point or an exponent must agree with the page's to one unit
of the last digit either side shows. Integers (counts, shapes, sizes) must be equal.
"""

import doctest
import re

import numpy as np

#: Two routes to the same estimate, relative to its largest entry. The test problems have
#: condition numbers below 1e3 (whitened lead fields, innovation covariances) and run a few
#: hundred steps at most: eps (2.2e-16) x 1e3 x a few is 1e-13; 1e-12 leaves room for other
#: kernels and layouts, while a real difference (another prior, a channel dropped, a wrong
#: standardization) moves the leading digits.
ROUTE_RTOL = 1e-12

#: Two routes to an estimate whose priors each route chose by maximizing the marginal
#: likelihood. The log-likelihood (about 1e4 in size) rounds at about 1e-11 on another
#: kernel or thread count; near its maximum, with a curvature of order 1 per dB squared,
#: that moves the optimum by up to sqrt(2 x 1e-11) ~ 5e-6 dB, and the estimate with it by
#: about 1e-6 of its size. A real difference (another prior range, another channel set)
#: moves the leading digits.
TUNED_RTOL = 1e-6

_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def relative(actual, desired):
    """``max|actual - desired| / max|desired|`` over the entries finite in both (0 if equal).

    NaN must sit at the same places in both (a missing sample is missing on every route).
    """
    actual, desired = np.asarray(actual, dtype=float), np.asarray(desired, dtype=float)
    assert actual.shape == desired.shape, (actual.shape, desired.shape)
    assert np.array_equal(np.isnan(actual), np.isnan(desired)), "NaN at other places"
    finite = np.isfinite(desired)
    if not finite.any():
        return 0.0
    scale = np.max(np.abs(desired[finite]))
    difference = np.max(np.abs(actual[finite] - desired[finite]))
    return float(difference / scale) if scale else float(difference)


def assert_same_to_rounding(actual, desired, rtol=ROUTE_RTOL, what=""):
    """Assert two routes' results equal to rounding (:data:`ROUTE_RTOL` of the larger)."""
    found = relative(actual, desired)
    assert found <= rtol, f"{what}: relative difference {found:.2e} > {rtol:.0e}"


def _unit(token):
    """One unit of the last digit a number's text shows (None for an integer)."""
    mantissa, _, exponent = token.lower().partition("e")
    if "." not in mantissa and not exponent:
        return None
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def _numbers_agree(printed, expected):
    if printed == expected:
        return True
    units = [u for u in (_unit(printed), _unit(expected)) if u is not None]
    if len(units) < 2:
        return False  # an integer on either side must be the same integer
    return abs(float(printed) - float(expected)) <= max(units) * (1 + 1e-9)


def align_numbers(printed, expected):
    """``printed`` with each number that agrees with ``expected``'s (in order) written as there.

    The texts are paired number by number; where the n-th numbers agree to one unit of the last
    digit either shows, the printed one is replaced by the expected text, so a comparison of
    the result with ``expected`` fails only on a real difference.
    """
    wanted = iter(_NUMBER.findall(expected))
    pieces, start = [], 0
    for match in _NUMBER.finditer(printed):
        target = next(wanted, None)
        if target is None:
            break
        pieces.append(printed[start : match.start()])
        pieces.append(target if _numbers_agree(match.group(), target) else match.group())
        start = match.end()
    return "".join(pieces) + printed[start:]


def same_printout(printed, expected):
    """Whether ``printed`` shows what ``expected`` does, line by line, numbers to their digits."""

    def lines(text):
        return [line.rstrip() for line in text.rstrip("\n").splitlines()]

    return lines(align_numbers(printed, expected)) == lines(expected)


class NumberChecker(doctest.OutputChecker):
    """doctest's checker, with numbers compared to the digits the page shows (as above)."""

    def check_output(self, want, got, optionflags):
        return super().check_output(want, got, optionflags) or super().check_output(
            want, align_numbers(got, want), optionflags
        )


def run_page_examples(path):
    """Run a page's ``>>>`` examples as :func:`doctest.testfile` does, with :class:`NumberChecker`.

    Returns doctest's ``TestResults(failed, attempted)``; failures are printed as doctest's.
    """
    text = path.read_text(encoding="utf-8")
    test = doctest.DocTestParser().get_doctest(
        text, {"__name__": "__main__"}, path.name, str(path), 0
    )
    runner = doctest.DocTestRunner(
        checker=NumberChecker(), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    runner.run(test)
    return runner.summarize(verbose=False)
