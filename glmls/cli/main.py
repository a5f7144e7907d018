"""The ``glmls`` command line: ``warp``, ``augment``, ``analyze``, ``tune``, ``study``, ``demo``
and ``bench``, each a module of this package with ``HELP``, ``EXAMPLES``, ``configure(parser)`` and
``run(args)``.

Exit status: 0 on success, 2 for usage and input errors (bad options, malformed files), 1 for
failures while running (no OpenGL, an unreadable image...). Messages and progress go to
stderr, results to stdout or files; a user's mistake never prints a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import textwrap
import threading
from collections.abc import Iterator, Sequence

from ..errors import GLUnavailableError, InputFileError
from ..version import __version__
from . import analyze, augment, bench, demo, study, tune, warp
from .options import ArgumentParser, HelpFormatter, UsageError

__all__ = ["EXIT_FAILURE", "EXIT_USAGE", "build_parser", "main"]

EXIT_USAGE = 2
EXIT_FAILURE = 1
COMMANDS = {
    "warp": warp,
    "augment": augment,
    "analyze": analyze,
    "tune": tune,
    "study": study,
    "demo": demo,
    "bench": bench,
}


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="glmls",
        description="Image deformation by Moving Least Squares on the GPU, with error analysis.",
    )
    parser.add_argument("--version", action="version", version=f"glmls {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress or messages")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, command in COMMANDS.items():
        sub = subparsers.add_parser(
            name,
            help=command.HELP,
            description=command.HELP,
            epilog=textwrap.dedent(command.EXAMPLES),
            formatter_class=HelpFormatter,
        )
        command.configure(sub)
        sub.add_argument(
            "--quiet",
            action="store_true",
            default=argparse.SUPPRESS,
            help="no progress or messages",
        )
        sub.set_defaults(run=command.run, command_parser=sub)
    return parser


#: The library's advice in keyword form, and the command line's options that say it.
_FLAGS = (("transform='similarity' or 'rigid'", "--transform similarity or rigid"),)


def in_flags(message: str) -> str:
    """``message`` (a library error's) with its advice in the command line's options."""
    for keyword, flag in _FLAGS:
        message = message.replace(keyword, flag)
    return message


class Terminated(BaseException):
    """SIGTERM, raised where the command runs, so that its cleanup runs as on Ctrl-C."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


@contextlib.contextmanager
def _terminate_as_exception() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` in the main thread while the command runs (a
    scheduler's or a container's stop then removes the temporaries, as Ctrl-C does)."""
    if threading.current_thread() is not threading.main_thread():
        yield  # Python sets handlers in the main thread only
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        # None: a handler that C code installed, which Python cannot set back.
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # the command's mistake: its name and its --help, not glmls's
        args.command_parser.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        with _terminate_as_exception():
            return args.run(args)
    except (UsageError, InputFileError) as error:
        print(f"glmls {args.command}: {in_flags(str(error))}", file=sys.stderr)
        return EXIT_USAGE
    except GLUnavailableError as error:
        print(f"glmls {args.command}: {error}", file=sys.stderr)
        return EXIT_FAILURE
    except OSError as error:
        print(f"glmls {args.command}: {error}", file=sys.stderr)
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print(f"glmls {args.command}: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print(f"glmls {args.command}: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM


if __name__ == "__main__":
    sys.exit(main())
