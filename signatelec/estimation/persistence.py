"""Model files that check themselves, and the cache of the default model.

A model file is one JSON header line, then the pickled
:class:`~signatelec.estimation.models.LoadStateModel`. The header carries the versions of
signatelec, of its feature set and of scikit-learn, the training summary, the length of the
pickle and the SHA-256 of everything else in the file (the header without its checksum, then
the pickle). :func:`load_model` checks, in this order, and refuses with a :class:`ModelError`
of one line naming the file before anything is unpickled:

1. the header: a file that is not a model (or whose header is damaged);
2. the versions: a model of another feature set, or of another signatelec or scikit-learn
   minor release (their fitted trees do not carry across), is to be retrained;
3. the length and the checksum: a truncated file, or one with any byte changed.

The checksum catches damage (a disk, a copy, an edit), not a forger: a pickle runs code when
loaded, so load only model files of a source you trust.

:func:`default_model` builds the default model (:func:`~signatelec.estimation.training.
train_default_model`) on first use and caches it under :func:`signatelec.io.cache_dir`; a
damaged cache entry is rebuilt with one warning line.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import pickle
import stat
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import sklearn

from signatelec._version import __version__
from signatelec.estimation.condition_features import CONDITION_FEATURE_SET_VERSION
from signatelec.estimation.features import FEATURE_SET_VERSION
from signatelec.estimation.models import LoadStateModel
from signatelec.estimation.training import (
    CALIBRATION_TABLE,
    CONDITION_TABLE,
    DEFAULT_RECIPE,
    DEFAULT_TABLE,
    PAPER_TABLE,
    STRETCH_TABLE,
    train_default_model,
)
from signatelec.io import cache_dir, write_bytes_atomic

MODEL_FORMAT = "signatelec-load-state-model"
#: 2: the header carries ``body_bytes`` and ``sha256``; 3: the model carries its training
#: domain (level range, in-domain score); 4: and the condition model beside the load state.
MODEL_FORMAT_VERSION = 4
#: Longest header line read (the header is ~1 kB).
MAX_HEADER_BYTES = 1 << 20
RETRAIN = "retrain it with `signatelec train DATASET --out MODEL`"


class ModelError(ValueError):
    """A model that cannot be used here: one line naming the file, the reason and what to do
    (``reason`` alone for messages of one's own)."""

    def __init__(self, path, reason: str, advice: str = "", *, subject: str = "model file"):
        self.path, self.reason = str(path), reason
        super().__init__(f"{subject} {self.path!r}: {reason}" + (f"; {advice}" if advice else ""))


def model_header(info: dict | None = None) -> dict:
    """The training summary ``info`` with the versions this signatelec writes and reads."""
    return {
        **(info or {}),
        "format": MODEL_FORMAT,
        "format_version": MODEL_FORMAT_VERSION,
        "signatelec": __version__,
        "feature_set": FEATURE_SET_VERSION,
        "condition_feature_set": CONDITION_FEATURE_SET_VERSION,
        "scikit_learn": sklearn.__version__,
        "numpy": np.__version__,
    }


def _checksum(header: dict, body: bytes) -> str:
    """SHA-256 of the header (its checksum left out, keys sorted) and the pickle."""
    fields = {k: v for k, v in header.items() if k != "sha256"}
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True).encode())
    digest.update(b"\n")
    digest.update(body)
    return digest.hexdigest()


def save_model(model: LoadStateModel, path: str | Path) -> None:
    """The header line and the pickled model, written atomically (OSError if unwritable)."""
    body = pickle.dumps(model, protocol=pickle.HIGHEST_PROTOCOL)
    header = model_header(model.info)
    header["features"] = model.features
    header["body_bytes"] = len(body)
    header["sha256"] = _checksum(header, body)
    write_bytes_atomic(path, json.dumps(header, sort_keys=True).encode() + b"\n" + body)


def _read(path: str | Path) -> tuple[dict, bytes]:
    """(header, pickle) of a model file; ModelError when it is no model file or its header is
    damaged."""
    try:
        with open(path, "rb") as fh:
            line = fh.readline(MAX_HEADER_BYTES)
            try:
                header = json.loads(line) if line.endswith(b"\n") else None
            except (ValueError, UnicodeDecodeError):
                header = None
            if not isinstance(header, dict) or header.get("format") != MODEL_FORMAT:
                if MODEL_FORMAT.encode() in line:  # ours, but the header is damaged
                    raise ModelError(
                        path, "checksum mismatch (corrupted or edited)", "retrain or delete it"
                    )
                raise ModelError(path, "not a signatelec load-state model (no model header)")
            return header, fh.read()
    except OSError as exc:
        raise ModelError(path, f"cannot be read ({exc.strerror or exc})") from None


def read_model_header(path: str | Path) -> dict:
    """The header of a model file (versions, training summary, checksum), unverified."""
    return _read(path)[0]


def check_compatible(header: dict, path: str | Path) -> None:
    """Refuse a model trained with another feature set, signatelec or scikit-learn release, or
    written in an older model format (without its training domain)."""
    here = model_header()
    if header.get("format_version") != MODEL_FORMAT_VERSION:
        raise ModelError(
            path,
            f"model format {header.get('format_version')} (signatelec "
            f"{header.get('signatelec')}); this signatelec {__version__} reads format "
            f"{MODEL_FORMAT_VERSION} (a model that carries its training domain and the "
            "condition model)",
            RETRAIN,
        )
    if header.get("condition_feature_set") != CONDITION_FEATURE_SET_VERSION:
        raise ModelError(
            path,
            f"trained on condition feature set {header.get('condition_feature_set')} "
            f"(signatelec {header.get('signatelec')}); this signatelec {__version__} computes "
            f"condition feature set {CONDITION_FEATURE_SET_VERSION}",
            RETRAIN,
        )
    if header.get("feature_set") != FEATURE_SET_VERSION:
        raise ModelError(
            path,
            f"trained on feature set {header.get('feature_set')} (signatelec "
            f"{header.get('signatelec')}); this signatelec {__version__} computes feature set "
            f"{FEATURE_SET_VERSION}",
            RETRAIN,
        )
    for key, name in (("signatelec", "signatelec"), ("scikit_learn", "scikit-learn")):
        theirs = str(header.get(key, "?"))
        if theirs.split(".")[:2] != here[key].split(".")[:2]:
            raise ModelError(
                path,
                f"trained with {name} {theirs}, this is {name} {here[key]} (models do not carry "
                "across minor releases)",
                RETRAIN,
            )


def _check_intact(header: dict, body: bytes, path: str | Path) -> None:
    """Refuse a file without a checksum, truncated, or whose checksum does not match."""
    expected, size = header.get("sha256"), header.get("body_bytes")
    if not isinstance(expected, str) or not isinstance(size, int):
        raise ModelError(path, "has no checksum (written by an older signatelec)", RETRAIN)
    if len(body) < size:
        raise ModelError(
            path, f"truncated ({len(body)} of {size} bytes of the model)", "retrain or delete it"
        )
    if len(body) != size or _checksum(header, body) != expected:
        raise ModelError(path, "checksum mismatch (corrupted or edited)", "retrain or delete it")


def load_model(path: str | Path, log: Callable[[str], None] | None = None) -> LoadStateModel:
    """Read a model file after checking its header, versions, length and checksum;
    :class:`ModelError` (one line) when it cannot be used. ``log`` gets one line when a part of
    the model is left unused (a condition model of one condition)."""
    header, body = _read(path)
    check_compatible(header, path)
    _check_intact(header, body, path)
    try:
        model = pickle.loads(body)
    except Exception as exc:  # a foreign pickle with a valid checksum: one line, no traceback
        raise ModelError(path, f"the model cannot be read ({type(exc).__name__})") from None
    if not isinstance(model, LoadStateModel) or model.domain is None:
        raise ModelError(path, "does not hold a load-state model with its training domain")
    condition = getattr(model, "condition", None)
    if condition is not None and len(condition.estimator.classes_) < 2:
        # a file trained on one condition (a healthy dataset's) before such a table trained
        # none: it would call every trace that one, with certainty
        model.condition = None
        if log is not None:
            log(
                f"warning: model file {str(path)!r}: its condition model knows one condition "
                f"({', '.join(map(str, condition.estimator.classes_))}); the bearing's condition "
                "is not assessed"
            )
    return model


# --- the default model ------------------------------------------------------------------------


def default_model_path(table: Path = DEFAULT_TABLE) -> Path:
    """The cache entry of the default model: one per release, feature set, model format,
    training recipe, scikit-learn and shipped tables (load state, paper-fidelity load state,
    stretches, condition, calibration)."""
    digest = hashlib.sha256(table.read_bytes())
    for shipped in (PAPER_TABLE, STRETCH_TABLE, CONDITION_TABLE, CALIBRATION_TABLE):
        if shipped.is_file():
            digest.update(shipped.read_bytes())
    digest = digest.hexdigest()[:10]
    name = (
        f"load_state-{__version__}-fs{FEATURE_SET_VERSION}-m{MODEL_FORMAT_VERSION}-"
        f"r{DEFAULT_RECIPE}-sklearn{sklearn.__version__}-{digest}.model"
    )
    return cache_dir("models") / name


def default_model(log: Callable[[str], None] | None = None) -> LoadStateModel:
    """The model trained on the shipped feature table, built on first use and cached
    (``$SIGNATELEC_CACHE_DIR/models``, default ``~/.cache/signatelec/models``).

    ``log`` gets one line when the model is built: that it is built once, or a warning that the
    cache entry was damaged and is rebuilt.
    """
    if not DEFAULT_TABLE.is_file():
        raise ModelError(
            DEFAULT_TABLE,
            "missing",
            "give --model or run pipelines/load_state.py --ship",
            subject="the default model's shipped feature table",
        )
    path = default_model_path()
    message = (
        f"building the default model from {DEFAULT_TABLE.name} and {PAPER_TABLE.name} (once; "
        f"cached in {path.parent})"
    )
    seen = _stamp(path)
    if seen is not None:
        try:
            return load_model(path)
        except ModelError as exc:
            message = (
                f"warning: the cached default model {str(path)!r} is unusable: {exc.reason}; "
                "rebuilding it"
            )
    with _build_lock(path):
        if _stamp(path) not in (None, seen):  # another process built it meanwhile
            with contextlib.suppress(ModelError):
                return load_model(path)
        if log is not None:
            log(message)
        model = train_default_model()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            save_model(model, path)
        except OSError:
            pass  # an unwritable cache only costs the rebuild next time
    return model


def _stamp(path: Path) -> tuple[int, int] | None:
    """(modification time in ns, size) of ``path``, None if it is not a file."""
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size) if stat.S_ISREG(st.st_mode) else None


@contextlib.contextmanager
def _build_lock(path: Path) -> Iterator[None]:
    """An exclusive lock (POSIX ``flock`` on ``path`` + ``.lock``) held while the default model
    is built: processes that ask for it meanwhile (the workers of a test run, jobs started
    together) wait and then read what the first built, instead of building it each (~100 s
    of two cores). No lock where there is no ``fcntl`` or the cache cannot be written; the
    lock goes with the process that holds it, whatever ends it."""
    try:
        import fcntl

        path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(path.with_name(path.name + ".lock"), "a")  # noqa: SIM115
    except (ImportError, OSError):
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
