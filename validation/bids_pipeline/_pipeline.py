"""``mne_bids_pipeline`` as its command runs it, with the report's 3-D figures stubbed
where no 3-D backend loads (no Qt or notebook, e.g. a headless machine): the pipeline's
steps ``source/make_forward`` and ``source/make_inverse`` add a 3-D coregistration,
sensitivity map and source estimate to the HTML report and stop if they cannot. The
stubs add a note to the report in place of the figure; nothing else changes.

Usage: ``python -m validation.bids_pipeline._pipeline --config=... --steps=...``.
"""

from __future__ import annotations

import mne


def _no_3d_backend() -> str | None:
    from mne.viz.backends.renderer import _get_3d_backend

    try:
        _get_3d_backend()
    except RuntimeError as err:
        return str(err).splitlines()[0]
    return None


def _stub(name: str, reason: str):
    def add(self, *args, title="", **kwargs):
        self.add_html(f"<p>{name} not rendered: {reason}</p>", title=title or name, replace=True)

    return add


def main() -> None:
    reason = _no_3d_backend()
    if reason is not None:
        for name in ("add_trans", "add_forward", "add_stc"):
            setattr(mne.Report, name, _stub(name, reason))
        print(f"validation.bids_pipeline: report 3-D figures stubbed ({reason})")
    from mne_bids_pipeline._main import main as pipeline

    pipeline()


if __name__ == "__main__":
    main()
