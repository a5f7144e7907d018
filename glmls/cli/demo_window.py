"""What ``glmls demo`` does with a window once it is made (the image's or the volume's): run
it for the replay, frames and screenshot asked for, and turn what stops it into an exit
status and a one-line message."""

from __future__ import annotations

import argparse
import sys

__all__ = ["fail", "replay_events", "run_window", "window_options"]


def fail(status: int, message: str) -> int:
    """Print ``glmls demo: message`` on standard error, as every command says its errors;
    ``status``."""
    print(f"glmls demo: {message}", file=sys.stderr)
    return status


def replay_events(args: argparse.Namespace) -> list | None:
    """The events of ``--replay``, or None."""
    from ..app.events import read_events

    return read_events(args.replay) if args.replay is not None else None


def window_options(args: argparse.Namespace) -> dict:
    """The keywords of either window that the arguments give: where it saves, the handles
    file it loads, its size, the file it records the events to, and the files it read, which
    its saves do not replace (the --handles file aside: ``j`` saves the handles edited)."""
    read = (
        (getattr(args, "image", None), "the input"),
        (args.targets, "the --targets file"),
        (getattr(args, "reference", None), "the --reference file"),
        (args.replay, "the --replay file"),
    )
    return {
        "out_dir": args.out,
        "handles_path": args.handles,
        "targets_path": args.targets,
        "window_size": args.window_size,
        "record": args.record,
        "read_files": {path: what for path, what in read if path is not None},
    }


def start_settings(args: argparse.Namespace, *names: str) -> dict:
    """A window's first settings from the options given: the MLS configuration, ``--method``,
    ``--interpolation``, ``--grid``, ``--border`` and ``names``; an option left out (None)
    is left to the window's own default."""
    from .options import config_from_args

    fields = ("method", "interpolation", "grid", "border", *names)
    given = {"config": config_from_args(args), **{name: getattr(args, name) for name in fields}}
    return {name: value for name, value in given.items() if value is not None}


def run_window(app, args: argparse.Namespace, events: list | None) -> int:
    """Run ``app`` (replaying ``events``) as the arguments ask; the exit status."""
    from ..app.events import replay_frames
    from ..app.glfw_window import NoDisplayError
    from ..errors import GLUnavailableError

    frames = args.frames
    if frames is None and (events is not None or args.screenshot is not None):
        frames = replay_frames(events or []) + 1
    try:
        app.run(events=events, frames=frames, screenshot=args.screenshot)
    except (NoDisplayError, GLUnavailableError) as error:
        return fail(1, str(error))
    except (ValueError, TypeError) as error:  # e.g. an image over the GL texture limit
        return fail(2, str(error))
    except OSError as error:  # the screenshot could not be written
        return fail(1, str(error))
    except KeyboardInterrupt:
        return 130
    return 0
