"""Command line: ``xcheck --version``, ``xcheck list`` (more commands arrive with the study and report)."""

from __future__ import annotations

import argparse
import sys

from . import __version__
from .rotations import EULER_SEQUENCES


def _cmd_list(args) -> int:
    print("Euler sequences: " + " ".join(EULER_SEQUENCES))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="xcheck", description="MuJoCo-validated rigid-body attitude cross-checker")
    parser.add_argument("--version", action="version", version=f"xcheck {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    p = sub.add_parser("list", help="bundled scenarios and methods")
    p.set_defaults(func=_cmd_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 2
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
