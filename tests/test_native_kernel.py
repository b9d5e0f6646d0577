"""The kernel linked from its cached object code without numba (engines/dem/native.py).

It must be the kernel numba runs, to round-off (the entry links the kernel's code and LLVM
optimises it once more: measured identical for the seed's kernel, at most 1 ulp, 7e-16 relative,
in the kinetic energy with the cage off); a damaged object must be rebuilt with one warning;
and a ``simulate`` process whose kernel is cached must import neither numba nor pandas (their
import and numba's loading of a cached kernel were three quarters of the seed run's start-up).
"""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest

from signatelec import io
from signatelec.config.scene import Scene
from signatelec.engines.dem import build, native
from signatelec.engines.dem.records import new_recording
from signatelec.engines.dem.run import initial_state, kernel_parameters
from signatelec.engines.dem.spec import KernelSpec
from signatelec.io import CacheWarning


def _steps(kernel, scene: Scene, n_steps: int = 20_000, every: int = 100):
    """State and recording after ``n_steps`` steps of ``scene`` from rest."""
    p, st = kernel_parameters(scene), initial_state(scene)
    rec = new_recording(n_steps // every, scene.bearing.n_balls)
    kernel.start(p, st)
    done = 0
    index = 0
    while done < n_steps:  # in chunks, as simulate_dem calls it
        index = kernel.run(p, st, rec, done, 5_000, every, index)
        done += 5_000
    return st, rec, index


@pytest.mark.parametrize("changes", [{}, {"cage": "none", "energy": True}], ids=["seed", "no-cage"])
def test_the_native_kernel_is_numbas_to_round_off(changes, tmp_path, monkeypatch):
    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(build, "_LOADED", {})
    scene = Scene().with_overrides(**changes)
    spec = KernelSpec.from_scene(scene)
    p, st = kernel_parameters(scene), initial_state(scene)
    calls = {"start": (p, st), "run": (p, st, new_recording(1, scene.bearing.n_balls), 0, 0, 1, 0)}
    linked = build.get_kernel(spec, calls=calls)
    assert isinstance(linked, native.NativeKernel)
    assert build.get_kernel(spec, calls=calls) is linked  # one per process
    module = build.prepare(build.get_kernel(spec), spec, calls)
    st_a, rec_a, n_a = _steps(linked, scene)
    st_b, rec_b, n_b = _steps(module, scene)
    assert n_a == n_b == 200
    for a, b in zip((*st_a, *rec_a), (*st_b, *rec_b), strict=True):
        np.testing.assert_allclose(a, b, rtol=4e-15, atol=0.0)  # a few ulp
    # the balls are loaded and rolling by then: the comparison covers the contact forces
    assert rec_a.fcon[-1, :, 0].max() > 100.0


def test_a_damaged_native_kernel_is_rebuilt_with_one_warning(tmp_path, monkeypatch):
    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(build, "_LOADED", {})
    scene = Scene()
    spec = KernelSpec.from_scene(scene)
    p, st = kernel_parameters(scene), initial_state(scene)
    calls = {"start": (p, st), "run": (p, st, new_recording(1, scene.bearing.n_balls), 0, 0, 1, 0)}
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        reference = _steps(build.get_kernel(spec, calls=calls), scene, 5_000)[1].fcon
    (path,) = (tmp_path / "kernels").glob("signatelec_kernel_*.native")
    data = path.read_bytes()
    path.write_bytes(data[:-100] + bytes(100))  # the object's end overwritten
    build._LOADED.clear()  # a new process
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = _steps(build.get_kernel(spec, calls=calls), scene, 5_000)[1].fcon
    messages = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert len(messages) == 1 and "unreadable" in messages[0] and "rebuilt" in messages[0]
    assert "\n" not in messages[0]
    assert native.read_native(path.with_suffix(".py")) is not None  # whole again
    np.testing.assert_array_equal(again, reference)


#: What a ``simulate`` of the seed's scene, its kernel cached, does without (start-up CPU of the
#: seed run, measured: numba's import and its loading of the cached kernel 0.39 s, pandas 0.26 s,
#: of 1.4 s; docs/bench/bench.md).
NOT_IMPORTED = ("numba", "pandas", "scipy", "sklearn", "matplotlib")


def test_a_cached_kernel_starts_without_numba_or_pandas(tmp_path):
    duration = Scene().setup_time_s + 0.001
    code = f"""
import sys
from signatelec.cli import main
main(["simulate", "--duration", "{duration}", "--quiet", "--out", sys.argv[1]])
print(",".join(m for m in {NOT_IMPORTED!r} if m in sys.modules))
"""
    for attempt in ("first", "cached"):  # the first may compile the kernel
        out = tmp_path / attempt
        done = subprocess.run(
            [sys.executable, "-c", code, str(out)], capture_output=True, text=True, timeout=300
        )
        assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == ""
    meta = io.read_metadata(out / "signals.parquet")
    assert 0.0 < meta["timings"]["process_to_first_step_s"]
