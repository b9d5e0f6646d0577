"""Kernels specialised per effect set.

:func:`get_kernel` copies ``kernel.py`` with its flag line set for one effect set into
the cache directory (``$SIGNATELEC_CACHE_DIR``, else ``~/.cache/signatelec``) and imports it;
numba's ``cache=True`` then keeps the machine code on disk, so each effect set compiles once per
machine and every later process (CLI runs, dataset workers) only loads it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import ModuleType

TEMPLATE = Path(__file__).with_name("kernel.py")
FLAG_NAMES = (
    "CAGE",
    "FRICTION",
    "DAMPING",
    "LINEAR",
    "SPRING",
    "GRAVITY",
    "CENTRIFUGAL",
    "ENERGY",
    "VERLET",
)
_FLAG_LINE = re.compile(r"^CAGE, FRICTION, .*$", re.MULTILINE)


@dataclass(frozen=True)
class KernelFlags:
    """Compile-time switches of one kernel; see the module docstring of kernel."""

    cage: bool = True
    friction: bool = True
    damping: bool = True
    linear: bool = False
    spring: bool = False
    gravity: bool = True
    centrifugal: bool = True
    energy: bool = False
    verlet: bool = True

    @classmethod
    def from_scene(cls, scene) -> KernelFlags:
        e = scene.effects
        return cls(
            cage=e.cage,
            friction=e.friction and scene.bearing.friction_coefficient > 0.0,
            damping=e.damping,
            linear=e.contact_law == "linear",
            spring=e.tangential == "spring",
            gravity=e.gravity,
            centrifugal=e.centrifugal,
            energy=e.energy,
            verlet=scene.numerics.integrator == "verlet",
        )

    @property
    def key(self) -> str:
        return "".join("1" if getattr(self, n.lower()) else "0" for n in FLAG_NAMES)


def cache_dir() -> Path:
    root = os.environ.get("SIGNATELEC_CACHE_DIR")
    base = Path(root) if root else Path.home() / ".cache" / "signatelec"
    return base / "kernels"


@cache
def get_kernel(flags: KernelFlags) -> ModuleType:
    """The kernel module for ``flags`` (compiled lazily by numba on first call)."""
    source = TEMPLATE.read_text(encoding="utf-8")
    values = ", ".join(str(getattr(flags, n.lower())) for n in FLAG_NAMES)
    specialised = _FLAG_LINE.sub(f"{', '.join(FLAG_NAMES)} = ({values})  # noqa: E501", source)
    digest = hashlib.sha1(specialised.encode()).hexdigest()[:10]
    name = f"signatelec_kernel_{flags.key}_{digest}"
    directory = cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{name}.py"
    if not path.exists():
        tmp = path.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(specialised, encoding="utf-8")
        os.replace(tmp, path)  # atomic: concurrent workers never import a half-written file
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
