"""docs/mne.md cannot rot: its examples run, in order, and print what the page shows.

As for docs/model.md (tests/test_model_doc.py): every ```python block runs in one
namespace, and what it prints (to standard output or, for the "skf_ref" log, standard
error) must equal the ```text block right after it.
"""

import contextlib
import io
from pathlib import Path

import mne
import pytest
from rounding import same_printout
from test_model_doc import _examples

DOC = Path(__file__).resolve().parent.parent / "docs" / "mne.md"
#: The page's examples run a recording and MEG with priors chosen by the data (the default):
#: about a minute, so CI runs them with the slow tests, not the README's test run.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def outputs():
    if not hasattr(mne.channels, "read_meg_canonical_info"):
        pytest.skip("the MEG example needs MNE >= 1.12 (its canonical sensor layouts)")
    namespace = {"__name__": "docs_mne_example"}
    printed_and_expected = []
    level = mne.set_log_level(None, return_old_level=True)
    try:
        for number, (code, expected) in enumerate(_examples(DOC.read_text("utf-8")), 1):
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
                exec(compile(code, f"docs/mne.md, python block {number}", "exec"), namespace)
            printed_and_expected.append((printed.getvalue(), expected))
    finally:
        mne.set_log_level(level)
    return printed_and_expected


def test_every_example_prints_what_the_page_shows(outputs):
    assert len(outputs) >= 8
    for number, (printed, expected) in enumerate(outputs, start=1):
        # numbers to the digits the page shows (tests/rounding.py)
        assert same_printout(printed, expected), f"docs/mne.md, python block {number}"
