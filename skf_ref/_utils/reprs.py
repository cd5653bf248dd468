"""How the package's objects show in a notebook (``_repr_html_``)."""

import html
from collections.abc import Mapping

__all__ = ["html_table"]


def html_table(title: str, rows: Mapping[str, object]) -> str:
    """A small HTML table of ``rows`` under ``title``, every text escaped.

    Parameters
    ----------
    title : str
    rows : mapping of str to object
        Row heading -> value (shown with ``str``).

    Returns
    -------
    str

    Examples
    --------
    >>> html_table("T", {"a": "<1>"})
    '<table><caption>T</caption><tr><th>a</th><td>&lt;1&gt;</td></tr></table>'
    """
    cells = "".join(
        f"<tr><th>{html.escape(str(key))}</th><td>{html.escape(str(value))}</td></tr>"
        for key, value in rows.items()
    )
    return f"<table><caption>{html.escape(title)}</caption>{cells}</table>"
