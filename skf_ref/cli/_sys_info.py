"""``skf-ref sys-info``: the machine, Python, the dependencies and the BLAS, for a bug report."""

from __future__ import annotations

import argparse

from ._args import Parser

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction[Parser]) -> None:
    """Add ``sys-info`` to the ``skf-ref`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``skf-ref``'s parser's ``add_subparsers`` returned.
    """
    parser = subparsers.add_parser(
        "sys-info",
        help="print the platform, Python, dependencies' versions and BLAS threads (for a "
        "bug report)",
        description="Print what a bug report needs: the platform, Python, CPUs and memory, "
        "the version of skf_ref and of each dependency, required and optional ('not "
        "installed' where absent), and the BLAS libraries with their threads "
        "(threadpoolctl). The same as skf_ref.sys_info() in Python.",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> None:
    """Run ``skf-ref sys-info``: print :func:`skf_ref.sys_info`.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``sys-info`` takes no options).
    """
    from .._utils.sys_info import sys_info

    sys_info()
