"""docs/model.md cannot rot: its worked example runs, prints what it shows, and agrees.

Every ```python block of the document is executed, in order, in one namespace; what a block
prints must equal the ```text block right after it (a block with no such text block must
print nothing). The numbers are then checked again as numbers, not as printed text.
"""

import contextlib
import importlib
import importlib.util
import io
import pkgutil
import re
from pathlib import Path

import numpy as np
import pytest
from rounding import same_printout

DOC = Path(__file__).resolve().parent.parent / "docs" / "model.md"

# A fenced block: opening fence (maybe indented, with a language), body, closing fence.
FENCE = re.compile(
    r"^(?P<indent> *)```(?P<lang>\w*)\n(?P<body>.*?)^(?P=indent)```[ \t]*$", re.M | re.S
)

# The filterpy path and the example's numpy lines (the dense path's algebra) compute the same
# in a different floating-point order: filterpy forms S_t^{-1} explicitly, updates P in Joseph
# form and inverts P_{t+1|t} in its smoother; the numpy lines use Cholesky solves and
# P - K S K^T. Their differences
# are a few units of eps (2.2e-16) times the condition numbers, which the example keeps
# below 20 (asserted below), so about 1e-14 at most; 1e-12 leaves room for other
# BLAS/LAPACK builds, while a real difference in the algebra (a wrong covariance, a missing
# transpose) would change the numbers in their leading digits.
RTOL = 1e-12
MAX_CONDITION = 20.0

# The sections the code cites as "docs/model.md §N".
SECTIONS = (1, 2, 3, 4, 5, 6, 7, 8)

# The packages whose modules the document names by their own name ("dense.rts").
PACKAGES = ("skf_ref.method._paths", "skf_ref.method", "skf_ref.study")
MODULES = tuple(
    info.name
    for package in PACKAGES
    for info in pkgutil.iter_modules(importlib.import_module(package).__path__)
)


def _blocks(text):
    return [(m["lang"], m["body"], m.start(), m.end()) for m in FENCE.finditer(text)]


def _examples(text):
    """(code, expected output) for every python block, in document order."""
    blocks = _blocks(text)
    pairs = []
    for i, (lang, body, _, end) in enumerate(blocks):
        if lang != "python":
            continue
        expected = ""
        if i + 1 < len(blocks):
            next_lang, next_body, next_start, _ = blocks[i + 1]
            if next_lang == "text" and not text[end:next_start].strip():
                expected = next_body
        pairs.append((body, expected))
    return pairs


@pytest.fixture(scope="module")
def text():
    return DOC.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def run(text):
    """Execute the examples; return the namespace and (printed, expected) per block."""
    namespace = {"__name__": "docs_model_example"}
    outputs = []
    with np.printoptions():  # the example sets print options; restore them afterwards
        for number, (code, expected) in enumerate(_examples(text), start=1):
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                exec(compile(code, f"docs/model.md, python block {number}", "exec"), namespace)
            outputs.append((printed.getvalue(), expected))
    return namespace, outputs


def test_sections_the_code_cites_exist_in_order(text):
    headings = [int(n) for n in re.findall(r"^## (\d+)\. ", text, re.M)]
    assert headings[: len(SECTIONS)] == list(SECTIONS)


def test_example_has_python_blocks_each_with_its_output(text):
    examples = _examples(text)
    assert len(examples) >= 5
    assert all(expected for _, expected in examples), "a python block lacks its text block"


def test_printed_output_is_the_documented_output(run):
    _, outputs = run
    for number, (printed, expected) in enumerate(outputs, start=1):
        # numbers to the digits the page shows: a value on a rounding boundary prints as
        # either neighbour on another BLAS kernel (tests/rounding.py)
        assert same_printout(printed, expected), f"python block {number}"


def test_filterpy_and_numpy_agree_numerically(run):
    ns, _ = run
    f, fp = ns["f"], ns["fp"]
    # the tolerance's premise: well-conditioned matrices
    assert max(np.linalg.cond(S) for S in fp["S"]) < MAX_CONDITION
    assert max(np.linalg.cond(P) for P in f["P_pred"]) < MAX_CONDITION
    for key in ("P_pred", "x_filt", "P_filt", "P_pred_inv_sqrt", "w", "weights", "z"):
        np.testing.assert_allclose(fp[key], f[key], rtol=0, atol=RTOL * np.abs(f[key]).max())
    assert ns["log_likelihood"] == pytest.approx(f["log_likelihood"], rel=RTOL)
    # both smoothers, filterpy's method against the example's own rts
    np.testing.assert_allclose(ns["s_fp"], ns["s"], rtol=0, atol=RTOL * np.abs(ns["s"]).max())
    x_s = ns["x_s"]
    np.testing.assert_allclose(ns["x_s_fp"], x_s, rtol=0, atol=RTOL * np.abs(x_s).max())


def test_last_smoothed_z_is_last_filtered_z(run):
    ns, _ = run
    z_filtered = ns["f"]["z"][-1]
    # the backward pass starts from the last filtered value and never rewrites it
    np.testing.assert_array_equal(ns["s"][-1], z_filtered)
    np.testing.assert_array_equal(ns["s_fp"][-1], ns["fp"]["z"][-1])
    np.testing.assert_array_equal(ns["x_s"][-1], ns["f"]["x_filt"][-1])
    # "rts-state" re-applies the filter's own W_T P_{T|T-1}^{-1/2} to the same x_{T|T}, by
    # a different product (einsum against @): equal up to the last bits
    np.testing.assert_allclose(ns["z_s"][-1], z_filtered, rtol=4 * np.finfo(float).eps)


def test_smoothers_differ_before_the_last_step(run):
    # the document's point in section 3: the two smoothers are not the same estimator
    ns, _ = run
    assert np.abs(ns["s"][0] - ns["z_s"][0]).max() > 1e-2


def _resolve(name):
    """The object a dotted name like ``dense.rts`` or ``KalmanFilter.update`` refers to.

    Names start with ``skf_ref``, a module of one of :data:`PACKAGES`, ``filterpy``, or
    ``KalmanFilter`` (filterpy's, which the subclass extends).
    """
    parts = name.split(".")
    if parts[0] == "KalmanFilter":
        parts = ["filterpy", "kalman", *parts]
    elif parts[0] not in ("skf_ref", "filterpy"):
        package = next(
            p for p in PACKAGES if importlib.util.find_spec(f"{p}.{parts[0]}") is not None
        )
        parts = [*package.split("."), *parts]
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[split:]:
            obj = getattr(obj, attribute)
        return obj
    raise ModuleNotFoundError(name)


def test_every_package_name_in_the_document_exists(text):
    prefixes = "|".join(("skf_ref", "filterpy", "KalmanFilter", *MODULES))
    names = set(re.findall(rf"`((?:{prefixes})(?:\.[A-Za-z_]\w*)+)`", text))
    assert len(names) > 30
    for name in sorted(names):
        try:
            _resolve(name)
        except (AttributeError, ModuleNotFoundError) as err:
            pytest.fail(f"docs/model.md names `{name}`, which does not exist ({err})")


def test_the_worked_example_uses_public_names_and_links_the_numpy_example(text):
    # Issue 41: a reader copies the example; a private module (skf_ref.method._paths...) is
    # no promise. The numpy-only version is the gallery's "SKF by hand".
    section = text[text.index("\n## 8. ") : text.index("\n## 9. ")]
    code = "\n".join(body for lang, body, _, _ in _blocks(section) if lang == "python")
    assert code.count("import") >= 3
    for name in re.findall(r"\bskf_ref(?:\.\w+)+", code):
        assert not any(part.startswith("_") for part in name.split(".")), name
    imported = re.findall(r"^from (\S+) import|^import (\S+)", code, flags=re.M)
    for module in (a or b for a, b in imported):
        assert not any(part.startswith("_") for part in module.split(".")), module
    assert "{doc}`auto_examples/plot_skf_by_hand`" in section
    assert (DOC.parent / "examples" / "plot_skf_by_hand.py").is_file()


# --- section 9, the equation-to-code map: every name it gives the dense and filterpy paths
# exists and is called when that path runs (issue 45) ---------------------------------------

_MAP_PATHS = {1: "dense", 2: "filterpy"}  # the map's columns


def _map_rows(text):
    """The cells of section 9's equation table, one list per row (header left out)."""
    section = text[text.index("\n## 9. ") :]
    table = section[section.index("| equation |") :].split("\n\n")[0].splitlines()[2:]
    return [[c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]] for line in table]


def _named(cell):
    """The dotted names in a cell: `dense.step`, `KalmanFilter.update` (an argument after a
    name, `KalmanFilter.update(None)`, left out)."""
    return re.findall(r"`([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?:\([^`]*\))?`", cell)


def _resolve_private(name):
    """:func:`_resolve`, with a module of ``skf_ref.method`` written without its underscore
    (``standardization.inverse_sqrt``), as section 9 writes them."""
    head, *rest = name.split(".")
    for package in PACKAGES:
        for module in (head, f"_{head}"):
            if importlib.util.find_spec(f"{package}.{module}") is not None:
                return _resolve(".".join([*package.split("."), module, *rest]))
    return _resolve(name)


def _code(obj):
    """The code object a call of ``obj`` runs (a function, a method or a property)."""
    obj = obj.fget if isinstance(obj, property) else obj
    return obj.__code__


def _map_names(text, column):
    """The names the map gives a path's column; "the same" takes the dense column's (but the
    dense module's own functions)."""
    names = set()
    for cells in _map_rows(text):
        cell = cells[column]
        names |= set(_named(cell))
        if column != 1 and cell.startswith("the same"):
            names |= {n for n in _named(cells[1]) if not n.startswith("dense.")}
    return names


def _called_on_path(path):
    """The code objects run by every smoother and standardization of one path, with a
    missing step (the paper's smoother on complete data)."""
    import sys

    import skf_ref

    rng = np.random.default_rng(9)
    L, Y = rng.standard_normal((5, 6)), rng.standard_normal((5, 4))
    gap = Y.copy()
    gap[:, 1] = np.nan
    called = set()

    def profile(frame, event, arg):
        if event == "call":
            called.add(frame.f_code)

    runs = [
        (data, smoother, standardize)
        for smoother in (None, "rts-standardized", "rts-state", "rts-smoothed-weights")
        for data in ((Y,) if smoother == "rts-standardized" else (Y, gap))
        for standardize in ("column", "position")
    ]
    sys.setprofile(profile)
    try:
        for data, smoother, standardize in runs:
            skf_ref.reconstruct(
                L,
                data,
                noise_std=1.0,
                theta0=1.0,
                q=0.1,
                exponent=1.25,
                smoother=smoother,
                path=path,
                standardize=standardize,
                n_orient=3,
            )
    finally:
        sys.setprofile(None)
    return called


@pytest.mark.parametrize("column", sorted(_MAP_PATHS))
def test_section_9_names_exist_and_are_called_on_their_path(text, column):
    names = _map_names(text, column)
    assert len(names) >= 8, names
    called = _called_on_path(_MAP_PATHS[column])
    for name in sorted(names):
        try:
            code = _code(_resolve_private(name))
        except (AttributeError, ModuleNotFoundError, StopIteration) as err:
            pytest.fail(f"docs/model.md §9 names `{name}`, which does not exist ({err})")
        assert code in called, (
            f"docs/model.md §9 names `{name}` for the {_MAP_PATHS[column]} path, which does not "
            "call it"
        )


def test_section_9_map_is_read_whole(text):
    # the parser's premise: the table's rows, each with its four columns
    rows = _map_rows(text)
    assert len(rows) >= 12 and all(len(cells) == 4 for cells in rows)
    assert "dense.step" in _map_names(text, 1)
    assert "filterpy_skf.StandardizedKalmanFilter.update" in _map_names(text, 2)
