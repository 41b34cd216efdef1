"""The `compass` command: one subcommand per module in this package.

Each subcommand module defines `HELP` (one line), `add_arguments(parser)` and
`run(args) -> int`. Bad input raises `CompassInputError`; it is printed as one line
`compass: error: ...` with exit code 2, never as a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import CompassInputError

#: subcommand -> module in this package (imported only when used, so heavy ones stay lazy).
SUBCOMMANDS = {
    "scenes": "scenes",
    "demo": "demo",
    "mbm": "mbm",
    "run": "run",
    "bench": "bench",
    "report": "report",
}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="compass", description="COMPASS confined-space manipulation on a CPU.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, module_name in SUBCOMMANDS.items():
        try:
            module = importlib.import_module(f"{__name__}.{module_name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"{__name__}.{module_name}":
                continue  # subcommand not present in this build
            raise
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except CompassInputError as exc:
        print(f"compass {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"compass {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
