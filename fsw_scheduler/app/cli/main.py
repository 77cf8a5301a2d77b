"""``fsw-scheduler``'s entry point: parse, dispatch, map errors to exit codes.

Exit codes: 0 success, 1 infeasible / unknown / violations, 2 bad input
(the message on stderr names the field) or a missing optional dependency.
"""

from __future__ import annotations

import logging
import sys
from typing import TYPE_CHECKING

from ...errors import ConfigError, InputError, SchedulerError
from .commands import EXIT_BAD_INPUT, EXIT_NO_PLAN, MissingDependency
from .parser import build_parser, log_level

if TYPE_CHECKING:
    from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``fsw-scheduler``; returns the exit code."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=log_level(args).upper(),
        format="%(asctime)s %(levelname)-7s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        return args.func(args)
    except InputError as error:
        print(f"fsw-scheduler: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (ConfigError, MissingDependency) as error:
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader went away (`... | head`): stop quietly, as a shell
        # tool killed by SIGPIPE would.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except TimeoutError as error:  # an OSError, but not bad input
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_NO_PLAN
    except SchedulerError as error:
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_NO_PLAN
    except Exception as error:
        # Unreadable or non-MCAP recordings are bad input, not crashes.
        if not _unreadable(error):
            raise
        where = (
            getattr(error, "filename", None)
            or " ".join(
                map(
                    str,
                    [
                        getattr(args, "file", None) or "",
                        *getattr(args, "files", []),
                    ],
                )
            ).strip()
        )
        print(f"fsw-scheduler: {where}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        return 130


def _unreadable(error: Exception) -> bool:
    """Whether ``error`` says a file could not be read (an OS error, or
    not MCAP). The MCAP reader is imported only then: a command that
    talks to a node never loads it."""
    if isinstance(error, OSError):
        return True
    from ...journal.reader import McapError

    return isinstance(error, McapError)
