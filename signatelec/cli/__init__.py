"""Command line: ``signatelec simulate | generate | figures | ...``.

Errors in the input print one line ``signatelec: error: <input>: <field> = <value>: <rule>`` and
exit with code 2, leaving nothing behind. Every exit code is listed in :data:`EXIT_CODES` (shown
by ``signatelec --help`` and in the README). Output directories follow the contract of
:mod:`signatelec.io`: checked before any work, replaced atomically, temporaries of killed runs
removed by the next run.
"""

from __future__ import annotations

import contextlib
import signal
import sys


def _interrupted_while_starting(signum, frame) -> None:
    """Ctrl-C before :func:`main` runs (the imports take a second): one line, exit 130."""
    sys.stderr.write("signatelec: interrupted\n")
    raise SystemExit(128 + signal.SIGINT)


with contextlib.suppress(ValueError):  # only the main thread may set handlers
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted_while_starting)


import click  # noqa: E402

from signatelec.cli import data, estimation, run, studies  # noqa: E402, F401  (they register)
from signatelec.cli.common import (  # noqa: E402
    EXIT_CODES,
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    InputError,
    Stopped,
    Terminated,
    cli,
    load_scene,
)
from signatelec.config.scene import SceneError  # noqa: E402
from signatelec.io import OutputError, clear_stops, record_stop  # noqa: E402

__all__ = ["EXIT_CODES", "EXIT_INPUT", "InputError", "cli", "load_scene", "main"]


def _raise_terminated(signum, frame) -> None:
    raise record_stop(Terminated())


def _raise_interrupted(signum, frame) -> None:
    raise record_stop(KeyboardInterrupt())


def one_line(text: str) -> str:
    """``text`` with line breaks and other control characters escaped (``\\r``, ``\\x1e``): an
    error stays one line whatever key, column or value of the input it names."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _error(message: str) -> None:
    click.echo(f"signatelec: error: {one_line(message)}", err=True)


def main(argv: list[str] | None = None) -> None:
    """The ``signatelec`` command; SIGTERM stops a run as Ctrl-C does (exit 143)."""
    previous = None
    with contextlib.suppress(ValueError):  # not the main thread: leave the handlers alone
        if signal.getsignal(signal.SIGINT) is _interrupted_while_starting:
            signal.signal(signal.SIGINT, _raise_interrupted)
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    unraisable = sys.unraisablehook

    def quiet_stop(hook_args) -> None:
        # a Ctrl-C or SIGTERM raised in a callback is recorded, and the command stops at its
        # next point with its one line: its traceback is not printed
        if not isinstance(hook_args.exc_value, KeyboardInterrupt):
            unraisable(hook_args)

    sys.unraisablehook = quiet_stop
    try:
        cli.main(args=argv, prog_name="signatelec", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.Abort:
        click.echo("signatelec: interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except (InputError, Stopped) as exc:
        _error(exc.format_message())
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        _error(exc.format_message())
        sys.exit(EXIT_INPUT)
    except (SceneError, OutputError) as exc:
        _error(str(exc))
        sys.exit(EXIT_INPUT)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = unraisable
        clear_stops()
