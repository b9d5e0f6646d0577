"""Shared pieces of the command line: exit codes, one-line errors, scene loading, output
locations, and the ``signatelec`` command group every command module registers on."""

from __future__ import annotations

import signal
from pathlib import Path

import click

from signatelec.config.scene import Scene, SceneError
from signatelec.interrupts import interruption
from signatelec.io import OutputError, OutputIncomplete, check_output_dir

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_DIVERGED = 3
#: EX_TEMPFAIL of sysexits.h: not complete; rerunning the same command can finish it.
EXIT_INCOMPLETE = 75
EXIT_INTERRUPTED = 128 + signal.SIGINT
EXIT_TERMINATED = 128 + signal.SIGTERM

EXIT_CODES = (
    (EXIT_OK, "complete"),
    (1, "unexpected error (a bug); the traces generate wrote are kept"),
    (EXIT_INPUT, "refused: bad input or output location; nothing written"),
    (EXIT_DIVERGED, "the simulation diverged; nothing written"),
    (
        EXIT_INCOMPLETE,
        "incomplete (disk full, I/O error, a worker or the cluster lost): simulate and figures "
        "wrote nothing, generate kept the traces written; rerun the same command to resume",
    ),
    (EXIT_INTERRUPTED, "interrupted (Ctrl-C); as 75"),
    (EXIT_TERMINATED, "terminated (SIGTERM); as 75"),
)


def _exit_code_table() -> str:
    """The exit codes as ``--help`` shows them (``\b``: click keeps the lines as they are)."""
    import textwrap

    lines = ["\b", "Exit codes:"]
    for code, text in EXIT_CODES:
        wrapped = textwrap.wrap(text, 66)
        lines.append(f"  {code:>3}  {wrapped[0]}")
        lines.extend(f"       {line}" for line in wrapped[1:])
    return "\n".join(lines)


class InputError(click.ClickException):
    exit_code = EXIT_INPUT


class Stopped(click.ClickException):
    """A run that stopped before completing; the message says what is kept."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the same clean-up runs."""


def _stop_code(exc: BaseException) -> int:
    return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED


def _stop_word(exc: BaseException) -> str:
    return "terminated" if isinstance(exc, Terminated) else "interrupted"


class _Group(click.Group):
    """A command interrupted by Ctrl-C or SIGTERM ends with one line and its exit code (click
    itself would print a blank line and "Aborted!")."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as exc:
            raise Stopped(_stop_word(exc), _stop_code(exc)) from None
        except SystemError as exc:
            if (stop := interruption(exc)) is None:
                raise
            raise Stopped(_stop_word(stop), _stop_code(stop)) from None


#: Command-line options of the scene parameters they override, to name them in errors.
OVERRIDE_OPTIONS = {
    "radial_load_n": "--radial-load",
    "clearance_m": "--clearance",
    "omega_rad_s": "--omega",
    "duration_s": "--duration",
    "dt_s": "--dt",
    "sample_rate_hz": "--sample-rate",
}


def scene_source(scene_file: str | None, overrides: dict | None = None) -> str:
    """Where a scene came from, for error messages: the file and the options that changed it."""
    where = f"scene {scene_file!r}" if scene_file is not None else "default scene"
    given = [
        f"{OVERRIDE_OPTIONS.get(k, k)} {v!r}" for k, v in (overrides or {}).items() if v is not None
    ]
    return f"{where} with {', '.join(given)}" if given else where


def load_scene(scene_file: str | None, **overrides) -> Scene:
    try:
        scene = Scene.from_toml(scene_file) if scene_file is not None else Scene()
    except SceneError as exc:
        message = str(exc)
        # a file that cannot be read or parsed names itself ("scene file '...': ...")
        where = "" if message.startswith("scene file") else f"{scene_source(scene_file)}: "
        raise InputError(f"{where}{message}") from None
    try:
        return scene.with_overrides(**overrides)
    except SceneError as exc:
        raise InputError(f"{scene_source(scene_file, overrides)}: {exc}") from None


def claim_output(out: str, command: str, **kwargs) -> Path:
    """Refuse, before a long run, an output location ``command`` may not write
    (:func:`signatelec.io.check_output_dir`); nothing is left behind."""
    try:
        return check_output_dir(out, command, **kwargs)
    except OutputError as exc:
        raise InputError(str(exc)) from None


@click.group(cls=_Group, epilog=_exit_code_table())
@click.version_option(package_name="signatelec")
def cli() -> None:
    """signatelec: DEM ball-bearing simulator and electrical resistance signatures."""


def write_output(write) -> None:
    """Call ``write`` (an atomic replacement of the output directory) and give each way it can
    fail its exit code: refused (2), not written (75), interrupted (130, 143); nothing written."""
    try:
        write()
    except OutputError as exc:
        raise InputError(str(exc)) from None
    except OutputIncomplete as exc:
        raise Stopped(str(exc), EXIT_INCOMPLETE) from None
    except KeyboardInterrupt as exc:
        raise Stopped(f"{_stop_word(exc)}; nothing written", _stop_code(exc)) from None


def check_writable_file(out: str, option: str = "--out", suffixes=None) -> None:
    """Fail early when a single output file cannot be written (its directory must exist)."""
    import os

    path = Path(out)
    if not out.strip() or path.is_dir():
        raise InputError(f"{option} {out!r}: must name a file")
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"{option} {out!r}: must end in {' or '.join(suffixes)}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {out!r}: {str(parent)!r} is not a writable directory")
