"""Files: Parquet tables with the scene in the schema metadata; output directories as a contract.

An output directory (``simulate``, ``figures``, ``generate``, ...) is written under these rules:

- **where**: a command writes only into a directory that is new, empty, or holds a previous
  output of the same command, recognised by the marker file ``.signatelec.json`` that names the
  command (written into every output), or, for an output written before the marker existed, by
  holding only the command's own files. Anything else is refused before any work;
- **names**: each component of the path is checked against the file system's ``NAME_MAX`` and
  the whole path against ``PATH_MAX`` before any work (temporary names have a fixed length);
- **atomic replacement**: a command that writes a directory as a whole writes it into a
  temporary directory beside the destination, flushes it to disk, then exchanges the two with
  one rename (``renameat2(RENAME_EXCHANGE)`` on Linux; elsewhere two renames) and removes the
  old one. A failure before the exchange leaves the old output as it was;
- **temporaries** are named ``.signatelec-<host>-<pid>-<random>.tmp``. A run removes those of a
  dead process of this host (a killed run's) in the directories it writes, never another file.
What signatelec can rebuild (compiled kernels, fitted models) lives under :func:`cache_root`,
``$SIGNATELEC_CACHE_DIR`` or ``~/.cache/signatelec``, one subdirectory each (:func:`cache_dir`).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import json
import os
import re
import secrets
import shutil
import socket
import tempfile
import warnings
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from signatelec._version import __version__
from signatelec.interrupts import signals_deferred

if TYPE_CHECKING:  # imported where used: reading a scene file needs neither
    import pandas as pd
    import pyarrow as pa

METADATA_KEY = b"signatelec"
#: The marker of an output directory: ``{"command": ..., "version": ...}``.
MARKER_FILE = ".signatelec.json"


#: The stop signals received (Ctrl-C, SIGTERM) as the exceptions they raise; see :func:`stop_now`.
_STOPS: list[BaseException] = []


def record_stop(exc: BaseException) -> BaseException:
    """Remember a stop signal's exception before it is raised: raised in an importer's or a
    finaliser's callback, Python only prints it ("Exception ignored in ...") and goes on, so a
    long job checks :func:`stop_now` at its own points as well. Returns ``exc``."""
    _STOPS.append(exc)
    return exc


def stop_now() -> None:
    """Raise (again) the first stop signal received, if any: at a point of a long job where it
    may stop (never inside a ``finally``)."""
    if _STOPS:
        raise type(_STOPS[0])()


def clear_stops() -> None:
    """Forget the stop signals received (a command that ended, in a process that goes on)."""
    _STOPS.clear()


class OutputError(OSError):
    """The output location is refused before any work; the message names it (nothing written)."""


class OutputIncomplete(OSError):
    """The output could not be completed (disk full, I/O error); the message says what is kept."""


class CacheWarning(UserWarning):
    """The cache could not be used as it was; the one-line message says what was done instead."""


def cache_root() -> Path:
    """``$SIGNATELEC_CACHE_DIR``, else ``~/.cache/signatelec`` (not created)."""
    root = os.environ.get("SIGNATELEC_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "signatelec"


_FALLBACK: dict[Path, Path] = {}


def cache_dir(name: str) -> Path:
    """``cache_root() / name``, created and writable; when it cannot be (read-only, a file in
    the way), a temporary directory used for the rest of the process, with one warning line."""
    wanted = cache_root() / name
    try:
        wanted.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=wanted, prefix=".probe-"):
            pass
        return wanted
    except OSError as exc:
        if wanted not in _FALLBACK:
            _FALLBACK[wanted] = Path(tempfile.mkdtemp(prefix=f"signatelec-{name}-"))
            warnings.warn(
                CacheWarning(
                    f"cache directory {str(wanted)!r} cannot be written "
                    f"({exc.strerror or exc}); using {_FALLBACK[wanted]} for this process"
                ),
                stacklevel=2,
            )
        return _FALLBACK[wanted]


def schema_with_metadata(schema: pa.Schema, metadata: dict) -> pa.Schema:
    """``schema`` with the signatelec metadata (the version and ``metadata``) under its key."""
    meta = dict(schema.metadata or {})
    meta[METADATA_KEY] = json.dumps({"version": __version__, **metadata}).encode()
    return schema.with_metadata(meta)


def table_with_metadata(df: pd.DataFrame, metadata: dict) -> pa.Table:
    import pyarrow as pa

    table = pa.Table.from_pandas(df, preserve_index=False)
    return table.replace_schema_metadata(schema_with_metadata(table.schema, metadata).metadata)


def read_metadata(path: str | Path) -> dict:
    """The signatelec metadata (scene, version, ...) stored in a Parquet file's schema."""
    import pyarrow.parquet as pq

    meta = pq.read_schema(path).metadata or {}
    return json.loads(meta.get(METADATA_KEY, b"{}"))


# --- temporaries and their owners ---------------------------------------------------------------

_HOST = hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]
_TEMPORARY = re.compile(
    r"^\.signatelec-(?P<host>[0-9a-f]{8})-(?P<pid>[0-9]{1,10})-[0-9a-f]{8}\.tmp$"
)
#: Longest temporary name, bytes (the pid has at most 10 digits).
TEMPORARY_NAME_MAX = len(".signatelec-") + 8 + 1 + 10 + 1 + 8 + len(".tmp")


def temporary_name() -> str:
    """A fresh temporary name of this process: ``.signatelec-<host>-<pid>-<random>.tmp``."""
    return f".signatelec-{_HOST}-{os.getpid()}-{secrets.token_hex(4)}.tmp"


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this host (a zombie, ended but not yet reaped by its
    parent, does not)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    except OverflowError:
        return False
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")
    except (OSError, IndexError):
        return True  # no /proc: the signal check is all there is


def stale_owner(name: str, legacy: re.Pattern | None = None) -> int | None:
    """The dead pid that left the temporary ``name`` on this host, else None (not a temporary,
    another host's, or its process still runs). ``legacy``: another pattern of temporaries with
    a ``pid`` group (names an older version used)."""
    match = _TEMPORARY.match(name)
    if match is not None and match["host"] != _HOST:
        return None
    if match is None and legacy is not None:
        match = legacy.match(name)
    if match is None:
        return None
    pid = int(match["pid"])
    return None if pid == os.getpid() or pid_alive(pid) else pid


def remove_stale_temporaries(directory: str | Path, legacy: re.Pattern | None = None) -> list[str]:
    """Remove the temporaries a dead process left in ``directory`` (files or directories);
    returns their names. Nothing else is touched."""
    removed = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        if stale_owner(entry.name, legacy) is None:
            continue
        with contextlib.suppress(OSError):
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
            removed.append(entry.name)
    return removed


# --- writing files ------------------------------------------------------------------------------


def fsync_directory(directory: str | Path) -> None:
    """Flush a directory's entries (renames into it) to disk, where the system allows it."""
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` at ``path`` under a temporary name beside it, fsync, rename."""
    path = Path(path)
    tmp = path.with_name(temporary_name())
    try:
        with open(tmp, "xb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_json_atomic(path: str | Path, data: dict) -> None:
    text = json.dumps(data, indent=2, sort_keys=True) + "\n"
    write_bytes_atomic(path, text.encode("utf-8"))


def read_limited(path: str | Path, limit_bytes: int) -> bytes:
    """The bytes of a file, refused beyond ``limit_bytes`` (a device such as /dev/zero or a huge
    file is stopped after reading one byte more than the limit). Raises OSError (EFBIG when too
    large, EISDIR for a directory)."""
    with open(path, "rb") as fh:
        if os.fstat(fh.fileno()).st_size > limit_bytes:
            raise OSError(errno.EFBIG, f"larger than {limit_bytes // 1024**2} MiB")
        data = fh.read(limit_bytes + 1)
    if len(data) > limit_bytes:
        raise OSError(errno.EFBIG, f"larger than {limit_bytes // 1024**2} MiB")
    return data


#: Largest trace file read: 1e7 samples of CSV are ~0.4 GB.
TRACE_MAX_BYTES = 1024**3


def input_size_problem(path: str | Path, limit_bytes: int) -> str | None:
    """Why an input file may not be read whole (None: it may, or it cannot be opened at all and
    its reader says why): larger than ``limit_bytes``, or a device or pipe, which has no size."""
    import stat

    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    if not stat.S_ISREG(info.st_mode) and not stat.S_ISDIR(info.st_mode):
        return "is not a regular file"
    if info.st_size > limit_bytes:
        size, limit = info.st_size / 1024**3, limit_bytes / 1024**3
        return f"is {size:.3g} GiB, larger than the {limit:.3g} GiB allowed"
    return None


# --- output locations ---------------------------------------------------------------------------


def _pathconf(directory: Path, name: str, default: int) -> int:
    try:
        value = os.pathconf(directory, name)
    except (OSError, ValueError):
        return default
    return value if value and value > 0 else default


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest existing ancestor (which may be a file)."""
    probe = path
    while probe != probe.parent:
        try:
            if probe.exists():
                return probe
        except OSError:
            pass
        probe = probe.parent
    return probe


def _nearest_directory(path: Path) -> Path:
    """The nearest existing directory among ``path`` and its ancestors."""
    probe = _nearest_existing(path)
    while not probe.is_dir() and probe != probe.parent:
        probe = probe.parent
    return probe


def check_path_names(path: str | Path, option: str = "--out", inner_bytes: int = 0) -> Path:
    """The absolute path, after checking every component against the file system's NAME_MAX and
    the whole path, plus ``inner_bytes`` of names a command adds below it, against PATH_MAX.
    Raises :class:`OutputError` naming the component; reads only existing parents."""
    text = os.fspath(path)
    absolute = Path(os.path.abspath(text))
    current = Path(absolute.anchor)
    exists = True
    for part in absolute.parts[1:]:
        size = len(os.fsencode(part))
        name_max = _pathconf(current if exists else _nearest_directory(current), "PC_NAME_MAX", 255)
        if size > name_max:
            shown = part if len(part) <= 40 else part[:37] + "..."
            raise OutputError(
                f"{option} {text!r}: the name {shown!r} is {size} bytes; the file system allows "
                f"at most {name_max} bytes per name"
            )
        current = current / part
        if exists:
            try:
                exists = current.exists()
            except OSError:
                exists = False
    path_max = _pathconf(_nearest_directory(absolute), "PC_PATH_MAX", 4096)
    total = len(os.fsencode(str(absolute))) + 1 + max(inner_bytes, TEMPORARY_NAME_MAX)
    if total >= path_max:
        raise OutputError(
            f"{option} {text!r}: the path (with the names written below it, {total} bytes) is "
            f"longer than the {path_max} bytes the system allows; choose a shorter path"
        )
    return absolute


def read_marker(directory: str | Path) -> dict | None:
    """The output marker of a directory, or None (no marker, or one that is not ours)."""
    try:
        data = json.loads(read_limited(Path(directory) / MARKER_FILE, 64 * 1024))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("command"), str) else None


def write_marker(directory: str | Path, command: str) -> None:
    write_json_atomic(Path(directory) / MARKER_FILE, {"command": command, "version": __version__})


def holds_only(directory: Path, names: Iterable[str], parquet_metadata: bool = True) -> bool:
    """Whether every entry of ``directory`` is one of ``names`` (with ``parquet_metadata``, a
    Parquet file among them must carry signatelec's): an output written before the marker."""
    import pyarrow as pa

    names = set(names)
    entries = list(directory.iterdir())
    if not entries or any(p.name not in names for p in entries):
        return False
    for p in entries:
        if parquet_metadata and p.suffix == ".parquet":
            try:
                if not p.is_file() or not read_metadata(p):
                    return False
            except (OSError, ValueError, pa.ArrowException):
                return False
    return True


def _content(directory: Path, ignore: Iterable[str]) -> list[str]:
    ignored = {MARKER_FILE, *ignore}
    return sorted(
        p.name for p in directory.iterdir() if p.name not in ignored and stale_owner(p.name) is None
    )


def refusal(directory: Path, command: str, ignore: Iterable[str] = ()) -> str | None:
    """Why ``command`` may not write into the existing ``directory`` (None: it may): it is empty
    (but for the marker, ``ignore`` and stale temporaries) or its marker names ``command``."""
    marker = read_marker(directory)
    if marker is not None:
        if marker["command"] == command:
            return None
        return (
            f"holds the output of signatelec {marker['command']}; {command} writes only into a "
            f"new or empty directory or one holding a previous {command} output"
        )
    entries = _content(directory, ignore)
    if not entries:
        return None
    shown = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
    return (
        f"is not empty ({shown}) and holds no output of signatelec {command}; choose a new or "
        "empty directory"
    )


def check_output_dir(
    out: str,
    command: str,
    *,
    option: str = "--out",
    previous: Callable[[Path], bool] | None = None,
    ignore: Iterable[str] = (),
    inner_bytes: int = 64,
    replaced: bool = True,
) -> Path:
    """Refuse, before any work, an output location ``command`` may not write (see the module
    docstring): raises :class:`OutputError` with one line naming the option and the reason.

    ``previous(directory)`` recognises an output of ``command`` without a marker (written by an
    older version); ``ignore``: names the command itself keeps in its directory (a lock file);
    ``replaced``: the command replaces the directory as a whole (:func:`replace_directory`), so
    it may not be the current directory or one of its ancestors, and its parent is written;
    otherwise the command writes inside it. The directory written must accept a new entry: it is
    probed with a temporary one, removed at once.
    """
    if not out.strip():
        raise OutputError(f"{option} {out!r}: must name a directory")
    absolute = check_path_names(out, option, inner_bytes)
    path = Path(out)
    if replaced:
        here = Path.cwd()
        if absolute == absolute.parent or absolute == here or absolute in here.parents:
            raise OutputError(
                f"{option} {out!r}: is the current directory or holds it; the output replaces "
                "the directory as a whole: name a directory inside it"
            )
    if path.exists() and not path.is_dir():
        raise OutputError(f"{option} {out!r}: exists and is not a directory; choose a directory")
    if path.is_dir():
        why = refusal(path, command, ignore)
        if why is not None and previous is not None and previous(path):
            why = None
        if why is not None:
            raise OutputError(f"{option} {out!r}: {why}")
    probe = _nearest_existing(absolute if not replaced else absolute.parent)
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {out!r}: {str(probe)!r} is not a writable directory")
    remove_stale_temporaries(probe)
    tmp = probe / temporary_name()
    try:
        tmp.mkdir()
        tmp.rmdir()
    except OSError as exc:
        raise OutputError(
            f"{option} {out!r}: cannot create files in {str(probe)!r} "
            f"({exc.strerror or exc}); choose a writable directory"
        ) from None
    return path


# --- replacing a directory atomically -------------------------------------------------------------

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux renameat2); False where the system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    c_int, c_path = ctypes.c_int, ctypes.c_char_p
    renameat2.argtypes = [c_int, c_path, c_int, c_path, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _flush_tree(directory: Path) -> None:
    for root, _, files in os.walk(directory):
        for name in files:
            with contextlib.suppress(OSError):
                fd = os.open(os.path.join(root, name), os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
        fsync_directory(root)


@contextmanager
def replace_directory(
    out: str | Path, command: str, *, previous: Callable[[Path], bool] | None = None
) -> Iterator[Path]:
    """Yield an empty temporary directory beside ``out``; when the block succeeds, mark it as
    ``command``'s output and put it in place of ``out`` atomically (the old output, if any, is
    removed). On failure ``out`` is left as it was and the temporary removed.

    ``out`` is checked again just before the exchange (it may have changed during the run).
    Raises :class:`OutputError` when ``out`` may not be replaced and :class:`OutputIncomplete`
    when the files cannot be written (disk full, I/O error).
    """
    out = Path(os.path.abspath(out))
    if out.is_symlink():  # replace what the link points to, not the link
        out = out.resolve()
    parent = out.parent
    existing = _nearest_existing(parent)  # the first directory made here is removed on failure
    created = None if existing == parent else existing / parent.relative_to(existing).parts[0]
    try:
        parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(parent)
        tmp = parent / temporary_name()
        tmp.mkdir()  # the usual mode: the umask applies, as to any directory a command makes
    except OSError as exc:
        raise OutputError(
            f"--out {str(out)!r}: cannot write there ({exc.strerror or exc}); choose a writable "
            "directory"
        ) from None
    try:
        try:
            yield tmp
            write_marker(tmp, command)
            _flush_tree(tmp)
        except OSError as exc:
            if isinstance(exc, (OutputError, OutputIncomplete)):
                raise
            raise OutputIncomplete(
                f"--out {str(out)!r}: cannot be written ({exc.strerror or exc}); nothing was "
                "written and any previous output is unchanged"
            ) from None
        # from the exchange to the old output's removal a Ctrl-C would report "nothing
        # written" with the new output in place: it is ignored there (the output completes)
        with signals_deferred():
            if out.is_dir():
                why = refusal(out, command)
                if why is not None and not (previous is not None and previous(out)):
                    raise OutputError(f"--out {str(out)!r}: {why}; nothing was written")
                if not _exchange(tmp, out):
                    old = parent / temporary_name()
                    os.rename(out, old)
                    try:
                        os.rename(tmp, out)
                    except OSError:
                        os.rename(old, out)
                        raise
                    tmp = old
            elif out.exists() or out.is_symlink():
                raise OutputError(
                    f"--out {str(out)!r}: exists and is not a directory; nothing written"
                )
            else:
                os.rename(tmp, out)
            fsync_directory(parent)
    finally:
        with signals_deferred():  # the temporary, or the old output once exchanged
            shutil.rmtree(tmp, ignore_errors=True)
            if created is not None and not out.exists():
                with contextlib.suppress(OSError):  # only directories left empty
                    for directory in (parent, *parent.parents):
                        os.rmdir(directory)
                        if directory == created:
                            break


def write_result(result, out_dir: str | Path) -> None:
    """Write ``balls.parquet`` and ``signals.parquet`` of a simulation result (the directory is
    replaced as a whole, see :func:`replace_directory`)."""
    import pyarrow.parquet as pq

    meta = {"scene": result.scene.to_dict(), "timings": result.timings}
    with replace_directory(out_dir, "simulate", previous=is_simulate_output) as tmp:
        for name in SIMULATE_FILES:
            table = table_with_metadata(getattr(result, name.removesuffix(".parquet")), meta)
            pq.write_table(table, tmp / name)


#: The files of a ``simulate`` output.
SIMULATE_FILES = ("balls.parquet", "signals.parquet")


def is_simulate_output(directory: Path) -> bool:
    """A ``simulate`` output written before the marker existed."""
    return holds_only(directory, SIMULATE_FILES)
