"""``python -m glmls.app [IMAGE] [--replay EVENTS.json] [--frames N] [--screenshot OUT.png]``."""

from __future__ import annotations

import argparse
import sys

from .command import configure_parser, run


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="glmls demo")
    configure_parser(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
