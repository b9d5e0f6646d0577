"""``signatelec generate``: labelled datasets."""

from __future__ import annotations

import click

from signatelec.cli.common import (
    EXIT_INCOMPLETE,
    InputError,
    Stopped,
    _stop_code,
    _stop_word,
    claim_output,
    cli,
)


@cli.command()
@click.argument("spec_file", metavar="SPEC.toml", type=str)
@click.option("--out", "out", type=str, required=True, help="Dataset directory (resumable).")
@click.option(
    "--workers",
    type=int,
    default=None,
    help="Local worker processes (default: all cores; 0: run in this process).",
)
@click.option(
    "--scheduler",
    type=str,
    default=None,
    help="Dask scheduler address (e.g. tcp://127.0.0.1:8786): run on that cluster instead.",
)
@click.option("--quiet", is_flag=True, help="No progress bar or summary.")
def generate(spec_file, out, workers, scheduler, quiet):
    """Labelled resistance signatures of a dataset spec: DIR/regime=*/trace-*.parquet.

    A rerun of the same command skips the traces already written (a killed job resumes).
    """
    from signatelec.data import DatasetDirError, SpecError, load_spec
    from signatelec.data import generate as run_generate
    from signatelec.data.schedule import kept, stop_reason
    from signatelec.data.store import LOCK_FILE, is_dataset

    try:
        spec = load_spec(spec_file)
    except SpecError as exc:
        raise InputError(str(exc)) from None
    if workers is not None and workers < 0:
        raise InputError(f"--workers {workers}: must be >= 0 (0: run in this process)")
    if workers is not None and scheduler:
        raise InputError(f"--workers {workers}: give --workers or --scheduler, not both")
    # below DIR: regime=<regime>/<temporary name of a part file>
    claim_output(
        out, "generate", previous=is_dataset, ignore=(LOCK_FILE,), inner_bytes=100, replaced=False
    )

    def log(line: str) -> None:
        click.echo(f"signatelec: warning: {line}", err=True)

    try:
        summary_ = run_generate(
            spec, out, workers=workers, scheduler=scheduler, progress=not quiet, log=log
        )
    except (SpecError, DatasetDirError) as exc:  # refused before any trace was written
        raise InputError(str(exc)) from None
    except KeyboardInterrupt as exc:
        raise Stopped(f"{_stop_word(exc)}; {kept(out, spec)}", _stop_code(exc)) from None
    except Exception as exc:
        resumable, reason = stop_reason(exc)
        code = EXIT_INCOMPLETE if resumable else 1
        raise Stopped(f"generation stopped ({reason}); {kept(out, spec)}", code) from None
    if not quiet:
        click.echo(summary_.describe())
