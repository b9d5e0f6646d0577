"""The kernel cache never serves stale physics and survives damage.

numba checks a cached function against the timestamp of its own file only; the kernel compiles
the contact laws of signatelec/physics/contact.py, so the cache key must cover that file (and
every other one the kernel compiles), the numba version and the signatelec version.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numba
import numpy as np
import pytest

import signatelec
import signatelec._version
from signatelec.config.scene import Scene
from signatelec.engines.dem import build
from signatelec.engines.dem.spec import KernelSpec
from signatelec.io import CacheWarning, cache_dir, cache_root

# A few thousand steps with friction and no cage: the load and the speed come as steps at t = 0,
# so the balls slip at once and the tangential forces reach hundreds of newtons.
SCENE_CODE = """
from signatelec.config.scene import Scene
scene = Scene().with_overrides(
    cage="none", gravity="none", electrical=False, clearance_phase=False, spin_up=False,
    load_ramp="step", clearance_time_s=0.0, load_time_s=0.0, spin_up_time_s=0.0,
    duration_s=3e-4, sample_rate_hz=1e5,
)
"""
RUN_CODE = f"""
import warnings
warnings.simplefilter("ignore")
{SCENE_CODE}
import signatelec
from signatelec.engines.simulate import simulate
print(signatelec.__file__, simulate(scene).balls.inner_tangential_n.abs().max())
"""


def short_scene() -> Scene:
    namespace: dict = {}
    exec(SCENE_CODE, namespace)
    return namespace["scene"]


def test_cache_key_changes_with_the_signatelec_and_numba_versions(monkeypatch):
    spec = KernelSpec.default()
    name, _ = build.kernel_name(spec)
    assert build.kernel_name(spec)[0] == name  # deterministic
    monkeypatch.setattr(signatelec._version, "__version__", "999.0")
    new_signatelec = build.kernel_name(spec)[0]
    monkeypatch.undo()
    monkeypatch.setattr(numba, "__version__", "0.0.1")
    new_numba = build.kernel_name(spec)[0]
    monkeypatch.undo()
    assert len({name, new_signatelec, new_numba}) == 3
    assert build.kernel_name(spec)[0] == name
    other = KernelSpec.from_scene(Scene().with_overrides(cage="none"))
    assert build.kernel_name(other)[0] != name


def test_cache_key_covers_every_module_the_kernel_compiles():
    sources = build.kernel_sources()
    assert {
        "signatelec.engines.dem.kernel",
        "signatelec.engines.dem.primitives",
        "signatelec.engines.dem.records",
        "signatelec.physics.contact",
    } <= set(sources)
    source = build.specialise(build.TEMPLATE.read_text(), KernelSpec.default())
    key = build.cache_key(source, sources, build.versions())
    edited = dict(sources)
    edited["signatelec.physics.contact"] += "\n# edited\n"
    assert build.cache_key(source, edited, build.versions()) != key


def test_specialise_writes_exactly_the_spec():
    template = build.TEMPLATE.read_text()
    # the template's own block reads as the seed scene's kernel
    listed = build._assignments(build._BLOCK.search(template).group(1))
    seed = KernelSpec.default().flags()
    assert listed == {name: seed[name] for name in listed}
    spec = KernelSpec.from_scene(
        Scene().with_overrides(cage="none", contact_law="linear", energy=True, integrator="euler")
    )
    source = build.specialise(template, spec)
    namespace: dict = {}
    block = build._BLOCK.search(source).group(1)
    exec(block, namespace)
    assert {k: v for k, v in namespace.items() if k.isupper()} == spec.flags()
    assert namespace["CAGE_NONE"] and not namespace["CAGE_BALLS"] and namespace["ENERGY"]
    with pytest.raises(RuntimeError, match="TYRE_PRESSURE"):
        build.specialise(template.replace("ENERGY = False", "TYRE_PRESSURE = 1"), spec)
    with pytest.raises(RuntimeError, match="0 kernel spec blocks"):
        build.specialise(template.replace("# --- kernel spec:", "# --- spec:"), spec)


def test_harris_and_hertz_share_a_kernel_and_friction_free_bearings_drop_friction():
    hertz = KernelSpec.from_scene(Scene())
    assert KernelSpec.from_scene(Scene().with_overrides(contact_law="harris")) == hertz
    frictionless = Scene(bearing=Scene().bearing.with_(friction_coefficient=0.0))
    spec = KernelSpec.from_scene(frictionless)
    assert spec["friction"] == "none" and spec.flags()["FRICTION_NONE"]


@pytest.mark.slow
def test_an_edited_contact_law_changes_the_kernel_that_runs(tmp_path):
    """Same cache directory, the package's tangential_force edited to return 0: the forces go."""
    copy = tmp_path / "pkg"
    package = Path(signatelec.__file__).parent
    shutil.copytree(package, copy / "signatelec", ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, PYTHONPATH=str(copy), SIGNATELEC_CACHE_DIR=str(tmp_path / "cache"))

    def max_tangential_n() -> float:
        out = subprocess.run(
            [sys.executable, "-c", RUN_CODE],
            env=env,
            cwd=tmp_path,  # not the checkout: "-c" puts the working directory first on sys.path
            capture_output=True,
            text=True,
            check=True,
        )
        imported, force = out.stdout.split()[-2:]
        assert Path(imported).is_relative_to(copy)
        return float(force)

    assert max_tangential_n() > 50.0  # mu F_n of a sliding ball, tens to hundreds of newtons
    contact = copy / "signatelec" / "physics" / "contact.py"
    text = contact.read_text()
    law = "    return -(stiffness_n_m * displacement_m + damping_n_s_m * slip_speed_m_s)\n"
    assert text.count(law) == 1
    contact.write_text(text.replace(law, "    return 0.0\n"))
    assert max_tangential_n() == 0.0


@pytest.mark.slow
def test_a_damaged_cache_is_rebuilt_with_one_warning(tmp_path, monkeypatch):
    from signatelec.engines.simulate import simulate

    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(build, "_LOADED", {})
    scene = short_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        reference = simulate(scene).balls.inner_tangential_n.to_numpy()
    (source,) = (tmp_path / "kernels").glob("signatelec_kernel_*.py")
    for ext in ("nbi", "nbc"):
        assert list(source.parent.glob(f"__pycache__/{source.stem}.*.{ext}"))

    def truncate(paths) -> None:
        for path in paths:
            data = path.read_bytes()
            path.write_bytes(data[: len(data) // 2])

    for damaged, expected in (
        ([source], "did not hold its kernel"),
        (source.parent.glob(f"__pycache__/{source.stem}.*.nbc"), "unreadable"),
        (source.parent.glob(f"__pycache__/{source.stem}.*.nbi"), "unreadable"),
    ):
        truncate(list(damaged))
        build._LOADED.clear()  # a new process
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            again = simulate(scene).balls.inner_tangential_n.to_numpy()
        messages = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
        assert len(messages) == 1 and expected in messages[0] and "rebuilt" in messages[0]
        assert "\n" not in messages[0]
        np.testing.assert_array_equal(again, reference)


def test_an_unusable_cache_directory_falls_back_to_a_temporary_one(tmp_path, monkeypatch):
    in_the_way = tmp_path / "a_file"
    in_the_way.write_text("not a directory")
    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(in_the_way))
    assert cache_root() == in_the_way
    with pytest.warns(CacheWarning) as caught:
        fallback = cache_dir("kernels")
    assert len(caught) == 1 and "\n" not in str(caught[0].message)
    assert str(in_the_way) in str(caught[0].message) and str(fallback) in str(caught[0].message)
    assert fallback.is_dir() and not fallback.is_relative_to(in_the_way)
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        assert cache_dir("kernels") == fallback  # one warning per process
        kernel = build.get_kernel(KernelSpec.default())  # written, not compiled
    assert Path(kernel.__file__).parent == fallback


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_a_read_only_cache_directory_falls_back_to_a_temporary_one(tmp_path, monkeypatch):
    root = tmp_path / "ro"
    root.mkdir()
    root.chmod(0o500)
    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(root))
    try:
        with pytest.warns(CacheWarning, match="cannot be written"):
            fallback = cache_dir("kernels")
        assert not fallback.is_relative_to(root)
    finally:
        root.chmod(0o700)
