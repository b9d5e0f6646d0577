"""The single-scene kernel as machine code loaded without numba: a process that finds its kernel
compiled starts in tens of milliseconds instead of several hundred.

Loading a kernel from numba's own cache costs more than running the seed's scene: numba has to
build its typing and target contexts (every implementation module, scipy's BLAS included) before
it hands over the machine code it stored. The machine code itself needs none of that. So the
first process to need a kernel compiles, with numba, one C-callable entry (:func:`_entry_source`,
a ``numba.cfunc`` calling the kernel's ``start`` or ``run`` on arrays given by address) and keeps
its object code beside the kernel (``<cache>/kernels/<kernel>.native``); every later process
links that object with llvmlite alone (:func:`load_native`) and calls it through ctypes.

The object is what numba compiled for this kernel, for this processor: its file holds the
processor name and features it was compiled for, the SHA-256 of the object code, and a stamp of
numba's cache files of the kernel (names, sizes, modification times). A change to any of them
(another machine sharing the cache, a damaged file, numba's cache rebuilt) sends the process
through numba again (:func:`signatelec.engines.dem.build.prepare`, which says what it rebuilt)
and a fresh object is written. The results are those of the numba-called kernel to round-off:
the entry links the kernel's code and LLVM optimises the whole once more, which may reorder a
fast-math sum (measured: identical for the seed's kernel, 1 ulp in the kinetic energy with the
cage off; tests/test_native_kernel.py). Every run of a kernel goes through the same object, so
runs repeat exactly.

The object refers to a few C helpers of numba's runtime (array reshaping, the error path of the
entry); they are taken from numba's own extension modules, loaded by file without importing the
numba package, and handed to LLVM's symbol table under the names numba gives them.
"""

from __future__ import annotations

import ctypes
import glob
import hashlib
import importlib.util
import json
import os
import warnings
from pathlib import Path

import numpy as np

from signatelec.engines.dem.records import PARAMS, Recording, State
from signatelec.io import CacheWarning

#: File format of a native kernel: this magic, a 4-byte little-endian header length, the JSON
#: header, then the object code.
MAGIC = b"SIGNATELEC-NATIVE-1\n"
#: The entry's arguments after its mode: the parameter record, State's arrays, Recording's
#: arrays, then Z, the recording's length, step0, n_steps, record_every, rec_index0.
_N_ARRAYS = 1 + len(State._fields) + len(Recording._fields)
_N_INTS = 6
_RUN, _START = 1, 0
_HELPERS_READY = False


def host_cpu() -> dict[str, str]:
    """The processor the object code is compiled for (LLVM's names)."""
    import llvmlite.binding as llvm

    return {"cpu": llvm.get_host_cpu_name(), "features": llvm.get_host_cpu_features().flatten()}


def numba_cache_stamp(kernel_path: Path) -> list:
    """Names, sizes and modification times of numba's cache files of the kernel at
    ``kernel_path`` (its ``__pycache__``), sorted."""
    pattern = str(kernel_path.parent / "__pycache__" / f"{glob.escape(kernel_path.stem)}.*")
    stamp = []
    for name in sorted(glob.glob(pattern)):
        try:
            st = os.stat(name)
        except OSError:
            continue
        stamp.append([os.path.basename(name), st.st_size, st.st_mtime_ns])
    return stamp


def native_path(kernel_path: Path) -> Path:
    return kernel_path.with_suffix(".native")


# --- compiling (numba) ------------------------------------------------------------------------


def _entry_source(carray, State, Recording, start, run):  # noqa: N803 (the classes)
    """The C-callable entry: ``entry(mode, p, state arrays..., recording arrays..., z, n_rec,
    step0, n_steps, every, rec_index0)`` calls ``run`` (mode 1, returns the next record index)
    or ``start`` (mode 0) on arrays built from the addresses (carray: no copy)."""

    def entry(
        mode, p, pos, vel, acc, spin, spin_acc, xi, roots, fcon, sched, energy, scratch, status,
        r_time, r_pos, r_vel, r_spin, r_fcon, r_sched, r_energy,
        z, n_rec, step0, n_steps, every, rec_index0,
    ):  # fmt: skip
        nb = 2 * z + 1
        s = State(
            carray(pos, (nb, 2)), carray(vel, (nb, 2)), carray(acc, (nb, 2)),
            carray(spin, (z,)), carray(spin_acc, (z,)), carray(xi, (z, 5)),
            carray(roots, (z, 20)), carray(fcon, (z, 6)), carray(sched, (4,)),
            carray(energy, (4,)), carray(scratch, (3 * z + 1, 2)), carray(status, (4,)),
        )  # fmt: skip
        record = carray(p, (1,))[0]
        if mode == 0:
            start(record, s)
            return 0
        rec = Recording(
            carray(r_time, (n_rec,)), carray(r_pos, (n_rec, nb, 2)),
            carray(r_vel, (n_rec, nb, 2)), carray(r_spin, (n_rec, z)),
            carray(r_fcon, (n_rec, z, 7)), carray(r_sched, (n_rec, 4)),
            carray(r_energy, (n_rec, 4)),
        )  # fmt: skip
        return run(record, s, rec, step0, n_steps, every, rec_index0)

    return entry


def compile_native(module) -> tuple[bytes, str]:
    """Object code and symbol of the C-callable entry of kernel ``module`` (numba compiles it;
    the kernel's own ``start`` and ``run`` come from its cache)."""
    import numba
    from numba import carray, types

    f8p, i8p = types.CPointer(types.float64), types.CPointer(types.int64)
    arrays = [types.CPointer(numba.from_dtype(PARAMS))]
    arrays += [f8p] * (len(State._fields) - 1) + [i8p]  # State.status is int64
    arrays += [f8p] * len(Recording._fields)
    signature = types.int64(types.int64, *arrays, *[types.int64] * _N_INTS)
    entry = _entry_source(carray, State, Recording, module.start, module.run)
    compiled = numba.cfunc(signature, error_model="numpy")(entry)
    return compiled._library._get_compiled_object(), compiled.native_name


def write_native(kernel_path: Path, module) -> bytes:
    """Compile the entry of ``module`` (the kernel at ``kernel_path``) and write its file
    atomically; returns the file's content."""
    obj, symbol = compile_native(module)
    header = {
        "symbol": symbol,
        "sha256": hashlib.sha256(obj).hexdigest(),
        "host": host_cpu(),
        "numba_cache": numba_cache_stamp(kernel_path),
    }
    head = json.dumps(header).encode("utf-8")
    data = MAGIC + len(head).to_bytes(4, "little") + head + obj
    path = native_path(kernel_path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)  # concurrent workers never read a half-written file
    return data


# --- loading (llvmlite) -----------------------------------------------------------------------


def _load_extension(name: str):
    """numba's C extension ``name`` loaded from its file, the numba package not imported."""
    spec = importlib.util.find_spec(name.split(".")[0])
    parts = name.split(".")[1:]
    directory = os.path.join(spec.submodule_search_locations[0], *parts[:-1])
    (path,) = glob.glob(os.path.join(glob.escape(directory), f"{parts[-1]}.*.so")) or [None]
    if path is None:
        raise ImportError(f"{name}: no extension module in {directory}")
    module_spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(module_spec)
    module_spec.loader.exec_module(module)
    return module


def _install_helpers() -> None:
    """numba's C helpers under the names its object code calls them (as numba itself does when
    its target context starts: numba.core.base, numba.core.runtime.nrt)."""
    global _HELPERS_READY
    if _HELPERS_READY:
        return
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    helperlib = _load_extension("numba._helperlib")
    nrt = _load_extension("numba.core.runtime._nrt_python")
    for prefix, module in (("numba_", helperlib), ("NRT_", nrt)):
        for name, address in module.c_helpers.items():
            llvm.add_symbol(prefix + name, address)
    _HELPERS_READY = True


def read_native(kernel_path: Path) -> tuple[dict, bytes] | None:
    """Header and object code of the native kernel beside ``kernel_path`` when it is whole and
    still matches this processor and numba's cache; None when it must be (re)built. A file that
    is there but damaged gives one warning line."""
    path = native_path(kernel_path)
    try:
        data = path.read_bytes()
    except OSError:
        return None
    try:
        if not data.startswith(MAGIC):
            raise ValueError("no header")
        n = int.from_bytes(data[len(MAGIC) : len(MAGIC) + 4], "little")
        start = len(MAGIC) + 4
        header = json.loads(data[start : start + n])
        obj = data[start + n :]
        if hashlib.sha256(obj).hexdigest() != header["sha256"]:
            raise ValueError("object code does not match its checksum")
    except (ValueError, KeyError, TypeError, UnicodeDecodeError) as exc:
        warnings.warn(
            CacheWarning(f"kernel cache: {path.name} unreadable ({exc}); rebuilt"), stacklevel=3
        )
        return None
    if header.get("numba_cache") != numba_cache_stamp(kernel_path):
        return None
    if header.get("host") != host_cpu():
        return None
    return header, obj


class NativeKernel:
    """The kernel's ``start`` and ``run`` with the signatures of the numba module's, calling the
    linked object code (the arrays are passed by address: no copy)."""

    def __init__(self, obj: bytes, symbol: str, name: str):
        import llvmlite.binding as llvm

        _install_helpers()
        target = llvm.Target.from_default_triple()
        host = host_cpu()
        machine = target.create_target_machine(
            cpu=host["cpu"], features=host["features"], codemodel="jitdefault", jit=True
        )
        self._engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), machine)
        self._engine.add_object_file(llvm.ObjectFileRef.from_data(obj))
        self._engine.finalize_object()
        address = self._engine.get_function_address(symbol)
        if not address:
            raise RuntimeError(f"native kernel {name}: symbol {symbol} not found")
        types = [ctypes.c_int64] + [ctypes.c_void_p] * _N_ARRAYS + [ctypes.c_int64] * _N_INTS
        self._call = ctypes.CFUNCTYPE(ctypes.c_int64, *types)(address)
        self.__name__ = name
        self._held = None  # the last call's arrays, kept alive with their addresses

    def _addresses(self, p, s: State, rec: Recording | None) -> list[int]:
        held = self._held
        if held is not None and held[0] is p and held[1] is s and held[2] is rec:
            return held[3]
        record = np.array(p, dtype=PARAMS)  # the kernel reads the parameters only
        arrays = [record, *s, *(rec if rec is not None else s[:7])]
        for a in arrays[1:]:
            if not (a.flags.c_contiguous and a.flags.aligned and a.dtype.kind in "fi"):
                raise ValueError("native kernel: arrays must be aligned, C-contiguous numbers")
        addresses = [a.__array_interface__["data"][0] for a in arrays]
        self._held = (p, s, rec, addresses, arrays)
        return addresses

    def start(self, p, s: State) -> None:
        z = s.spin.shape[0]
        self._call(_START, *self._addresses(p, s, None), z, 0, 0, 0, 1, 0)

    def run(self, p, s: State, rec: Recording, step0, n_steps, record_every, rec_index0) -> int:
        z = s.spin.shape[0]
        n_rec = rec.time_s.shape[0]
        addresses = self._addresses(p, s, rec)
        return int(self._call(_RUN, *addresses, z, n_rec, step0, n_steps, record_every, rec_index0))


def load_native(kernel_path: Path) -> NativeKernel | None:
    """The native kernel beside ``kernel_path`` (see :func:`read_native`), or None."""
    found = read_native(kernel_path)
    if found is None:
        return None
    header, obj = found
    return NativeKernel(obj, header["symbol"], kernel_path.stem)
