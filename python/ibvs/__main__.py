"""Command line: `ibvs` / `python -m ibvs`."""

from __future__ import annotations

import argparse
import sys

import ibvs


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="ibvs", description="Image-based visual servoing: Cartesian, polar and hybrid.")
    p.add_argument("--version", action="version", version=f"ibvs {ibvs.__version__}")
    p.add_argument("--cmake-dir", action="store_true", help="print the directory holding ibvsConfig.cmake and exit")
    p.add_subparsers(dest="command", metavar="COMMAND")
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cmake_dir:
        print(ibvs.cmake_dir())
        return 0
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
