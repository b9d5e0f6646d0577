"""Kernels specialised per :class:`~signatelec.engines.dem.spec.KernelSpec`, cached on disk
without ever serving stale physics.

:func:`get_kernel` writes ``kernel.py`` with its spec block set from the spec
(:func:`specialise`) into ``<cache>/kernels`` (``signatelec.io.cache_dir``) under a name made of
:func:`cache_key`, and imports it; numba's ``cache=True`` keeps the machine code next to it in
``__pycache__``, so each kernel compiles once per machine and every later process (CLI runs,
dataset workers) only loads it.

numba checks a cached function against the timestamp of its own file only, not against the
functions it calls from other files. The key therefore hashes the specialised source, the text of
every signatelec module the kernel imports, transitively (:func:`kernel_sources`: found from the
import statements, so a new import joins the key by itself), and the numba, numpy, Python and
signatelec versions (:func:`versions`). Editing a contact law in physics/contact.py, or
installing another version, gives another file name and a fresh compile.

A damaged cache is rebuilt, not fatal: a generated file that differs from what it should hold,
or numba index/data files it cannot read, give one warning line and a fresh compile; an
unusable cache directory gives one warning line and a temporary one (``signatelec.io``).

The single-scene kernel also keeps its machine code as an object file that later processes link
without importing numba (:mod:`signatelec.engines.dem.native`; ``get_kernel(spec, calls=...)``);
nothing here imports numba until a kernel has to be compiled or loaded by numba itself.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import os
import platform
import re
import sys
import traceback
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np

import signatelec._version
from signatelec.engines.dem.spec import KernelSpec
from signatelec.io import CacheWarning, cache_dir

TEMPLATE = Path(__file__).with_name("kernel.py")
TEMPLATE_MODULE = "signatelec.engines.dem.kernel"
#: The ensemble kernel (:mod:`.ensemble`): the same flags plus the batch's BALLS and LANES.
ENSEMBLE_TEMPLATE = Path(__file__).with_name("ensemble.py")
ENSEMBLE_MODULE = "signatelec.engines.dem.ensemble"
#: The functions called from Python, compiled (or loaded) before a run by :func:`prepare`.
ENTRY_POINTS = ("start", "run", "forces")
_BLOCK = re.compile(r"^# --- kernel spec:[^\n]*\n(.*?)^# --- end of kernel spec", re.M | re.S)
_LOADED: dict[tuple, ModuleType] = {}


def _assignments(block: str) -> dict[str, object]:
    """``NAME = literal`` lines of a spec block, by name."""
    out = {}
    for node in ast.parse(block).body:
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1):
            raise RuntimeError(f"kernel spec block: {ast.unparse(node)!r} is not NAME = value")
        out[node.targets[0].id] = ast.literal_eval(node.value)
    return out


def specialise(source: str, spec: KernelSpec, constants: dict[str, int] | None = None) -> str:
    """``source`` (the text of kernel.py) with its spec block assigning ``spec.flags()`` and
    ``constants`` (the ensemble kernel's BALLS and LANES).

    Raises RuntimeError when the source has not exactly one spec block, or when the block names
    a flag no kernel option defines (the kernel would read a constant no spec sets).
    """
    blocks = list(_BLOCK.finditer(source))
    if len(blocks) != 1:
        raise RuntimeError(f"kernel.py: {len(blocks)} kernel spec blocks; expected exactly one")
    block = blocks[0]
    flags = spec.flags() | dict(constants or {})
    unknown = sorted(set(_assignments(block.group(1))) - set(flags))
    if unknown:
        raise RuntimeError(f"kernel.py reads {', '.join(unknown)}: no kernel option defines it")
    lines = "".join(f"{name} = {value!r}\n" for name, value in flags.items())
    out = source[: block.start(1)] + lines + source[block.end(1) :]
    written = _assignments(_BLOCK.search(out).group(1))
    if written != flags:
        raise RuntimeError(f"kernel spec block: wrote {written}, meant {flags}")
    return out


def _top_level_imports(text: str) -> ast.Module:
    """The top-level import statements of module source ``text`` as a module (those the
    kernel's cache key follows): only the lines that start with ``import``/``from`` at column 0
    and their continuation are parsed, not the whole module (a tenth of the time). A docstring
    line that happens to parse as an import only adds a file to the key."""
    body = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if not line.startswith(("import ", "from ")):
            continue
        statement = line
        while (statement.count("(") > statement.count(")") or statement.endswith("\\")) and i < len(
            lines
        ):
            statement += "\n" + lines[i]
            i += 1
        try:
            body.extend(ast.parse(statement).body)
        except SyntaxError:  # prose in a docstring
            continue
    return ast.Module(body=body, type_ignores=[])


def _imported_modules(name: str, tree: ast.Module) -> set[str]:
    """signatelec modules that module ``name`` imports at its top level."""
    found = set()
    for node in tree.body:
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            package = name.rpartition(".")[0]
            try:
                base = importlib.util.resolve_name("." * node.level + (node.module or ""), package)
            except ImportError:  # a relative import in prose
                continue
            if not base.startswith("signatelec"):
                continue
            package_spec = importlib.util.find_spec(base)
            if package_spec is None:
                continue
            for alias in node.names:
                submodule = f"{base}.{alias.name}"
                is_module = package_spec.submodule_search_locations is not None and (
                    importlib.util.find_spec(submodule) is not None
                )
                found.add(submodule if is_module else base)
    return {m for m in found if m == "signatelec" or m.startswith("signatelec.")}


def kernel_sources(template_module: str = TEMPLATE_MODULE) -> dict[str, str]:
    """Source text of kernel.py (or ``template_module``) and of every signatelec module it
    imports (at top level, transitively), by module name: all the code, constants and types the
    kernel compiles."""
    sources: dict[str, str] = {}
    pending = [template_module]
    while pending:
        name = pending.pop()
        if name in sources:
            continue
        text = Path(importlib.util.find_spec(name).origin).read_text(encoding="utf-8")
        sources[name] = text
        pending.extend(_imported_modules(name, _top_level_imports(text)) - set(sources))
    return sources


def numba_version() -> str:
    """numba's version: ``numba.__version__`` once numba is imported, else read from its
    ``_version.py`` (the release's own record) without importing numba."""
    numba = sys.modules.get("numba")
    if numba is not None:
        return numba.__version__
    spec = importlib.util.find_spec("numba")
    try:
        text = Path(spec.submodule_search_locations[0], "_version.py").read_text("utf-8")
        return re.search(r'^ "version": "([^"]+)"', text, re.M).group(1)
    except (OSError, AttributeError, TypeError):
        from importlib.metadata import version

        return version("numba")


def versions() -> dict[str, str]:
    """What else the compiled code depends on."""
    return {
        "signatelec": signatelec._version.__version__,
        "numba": numba_version(),
        "numpy": np.__version__,
        "python": platform.python_version(),
        "implementation": sys.implementation.name,
    }


def cache_key(source: str, sources: dict[str, str], versions: dict[str, str]) -> str:
    """Hex digest of the specialised source, the sources it compiles and the versions."""
    h = hashlib.sha256()
    parts = [source, *(f"{n}\n{t}" for n, t in sorted(sources.items()))]
    parts += [f"{k}={v}" for k, v in sorted(versions.items())]
    for part in parts:
        h.update(part.encode("utf-8"))
        h.update(b"\0")
    return h.hexdigest()[:24]


def kernel_name(spec: KernelSpec, constants: dict[str, int] | None = None) -> tuple[str, str]:
    """Module name (from :func:`cache_key`) and specialised source of the kernel for ``spec``;
    with ``constants`` (BALLS, LANES), of the ensemble kernel."""
    template, module, prefix = TEMPLATE, TEMPLATE_MODULE, "signatelec_kernel"
    if constants is not None:
        template, module, prefix = ENSEMBLE_TEMPLATE, ENSEMBLE_MODULE, "signatelec_ensemble"
    source = specialise(template.read_text(encoding="utf-8"), spec, constants)
    return f"{prefix}_{cache_key(source, kernel_sources(module), versions())}", source


def get_kernel(
    spec: KernelSpec, constants: dict[str, int] | None = None, calls: dict[str, tuple] | None = None
):
    """The kernel module for ``spec`` (numba compiles or loads it on first call; see
    :func:`prepare`); with ``constants`` (``{"BALLS": Z, "LANES": L}``), the ensemble kernel
    for L scenes of Z balls.

    With ``calls`` (the single-scene kernel's entry points and arguments, as for
    :func:`prepare`), the kernel ready to call: its cached object code linked without numba
    (:class:`signatelec.engines.dem.native.NativeKernel`), or, the first time or when numba's
    cache of it changed, the module prepared by numba, its object code then written for the
    next processes."""
    if calls is not None and constants is None:
        return _native_kernel(spec, calls)
    directory = cache_dir("kernels")
    key = (spec, directory, tuple(sorted((constants or {}).items())), constants is None)
    loaded = _LOADED.get(key)
    if loaded is not None:
        return loaded
    name, source = kernel_name(spec, constants)
    path = directory / f"{name}.py"
    _write_source(path, source)
    module = _import(name, path, spec, constants)
    _LOADED[key] = module
    return module


def _native_kernel(spec: KernelSpec, calls: dict[str, tuple]):
    from signatelec.engines.dem.native import NativeKernel, load_native, read_native, write_native

    directory = cache_dir("kernels")
    key = ("native", spec, directory)
    loaded = _LOADED.get(key)
    if loaded is not None:
        return loaded
    name, source = kernel_name(spec)
    path = directory / f"{name}.py"
    _write_source(path, source)
    try:
        kernel = load_native(path)
    except (ImportError, OSError, RuntimeError):  # no native loading here: numba's own
        kernel = None
    if kernel is None:
        kernel = prepare(get_kernel(spec), spec, calls)
        try:
            # the entry links the kernel's compiled start and run; numba's cache is now whole
            write_native(path, kernel)
            header, obj = read_native(path)
            kernel = NativeKernel(obj, header["symbol"], name)
        except ImportError:
            pass  # no numba extension file to link against here: numba's module serves
        except Exception as exc:  # numba's module serves: a slower start, the same kernel
            warnings.warn(
                CacheWarning(
                    f"kernel cache: no native entry for {name} ({type(exc).__name__}); "
                    "numba loads the kernel in each process"
                ),
                stacklevel=3,
            )
    _LOADED[key] = kernel
    return kernel


def _write_source(path: Path, source: str) -> None:
    """Write ``source`` at ``path`` unless it is there already (rewriting the same text would
    change its timestamp and make numba recompile); replace a damaged one with a warning."""
    try:
        existing = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        existing = None
    except (OSError, UnicodeDecodeError):
        existing = ""
    if existing == source:
        return
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(source, encoding="utf-8")
    if existing is None:
        try:
            os.link(tmp, path)  # atomic create: a concurrent worker's identical file stays
        except FileExistsError:
            pass
        except OSError:
            os.replace(tmp, path)
        tmp.unlink(missing_ok=True)
        return
    warnings.warn(
        CacheWarning(f"kernel cache: {path} did not hold its kernel (damaged); rebuilt"),
        stacklevel=3,
    )
    os.replace(tmp, path)  # atomic: concurrent workers never import a half-written file
    _purge(path)


def _import(
    name: str, path: Path, spec: KernelSpec, constants: dict[str, int] | None = None
) -> ModuleType:
    module_spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module
    module_spec.loader.exec_module(module)
    flags = spec.flags() | dict(constants or {})
    got = {flag: getattr(module, flag, None) for flag in flags}
    if got != flags:
        raise RuntimeError(f"kernel {path}: flags {got}, meant {flags}")
    return module


def _purge(path: Path) -> None:
    """Remove numba's cache files of the kernel at ``path`` (index and data of every function)
    and its native object."""
    path.with_suffix(".native").unlink(missing_ok=True)
    numba_dirs = {path.parent / "__pycache__"}
    module = sys.modules.get(path.stem)
    for entry in ENTRY_POINTS:
        dispatcher = getattr(module, entry, None)
        cache = getattr(dispatcher, "_cache", None)
        if getattr(cache, "cache_path", None):
            numba_dirs.add(Path(cache.cache_path))
    for directory in numba_dirs:
        for file in directory.glob(f"{path.stem}.*"):
            file.unlink(missing_ok=True)


def _from_numba_cache(exc: BaseException) -> bool:
    frames = traceback.extract_tb(exc.__traceback__)
    return any(f.filename.endswith(os.path.join("numba", "core", "caching.py")) for f in frames)


def prepare(module: ModuleType, spec: KernelSpec, calls: dict[str, tuple]) -> ModuleType:
    """Compile, or load from the disk cache, the entry points named in ``calls`` for the types of
    their arguments, without running them. Numba cache files that cannot be read are removed
    with one warning line and the kernel compiled afresh. Returns the module to call."""
    import numba

    for attempt in range(2):
        try:
            for entry, args in calls.items():
                getattr(module, entry).compile(tuple(numba.typeof(a) for a in args))
            return module
        except Exception as exc:
            if attempt or not _from_numba_cache(exc):
                raise
            path = Path(module.__file__)
            warnings.warn(
                CacheWarning(
                    f"kernel cache: numba files of {path.name} unreadable "
                    f"({type(exc).__name__}); rebuilt"
                ),
                stacklevel=2,
            )
            _purge(path)
            constants = None
            if path.stem.startswith("signatelec_ensemble"):
                constants = {"BALLS": module.BALLS, "LANES": module.LANES}
            module = _import(path.stem, path, spec, constants)
            _LOADED.update(
                {
                    k: module
                    for k, v in _LOADED.items()
                    if k[0] != "native" and v.__name__ == path.stem
                }
            )
    raise AssertionError("unreachable")
