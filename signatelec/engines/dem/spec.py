"""The compile-time choices of one DEM kernel.

A :class:`KernelSpec` holds the value of every scene option the kernel is compiled per (the
entries of :data:`signatelec.config.options.OPTIONS` with ``kernel=True``), in table order. The
kernel source reads them as booleans, ``<OPTION>_<VALUE>`` for a model option (``CAGE_BALLS``,
``CONTACT_LAW_LINEAR``) and ``<OPTION>`` for a switch (``ENERGY``): :meth:`KernelSpec.flags`.
Adding a model is one value in ``OPTIONS`` and one branch on its flag in the kernel.

Besides the options, the scene's defects and abnormal loads set flags of their own
(:data:`SCENE_FLAGS`, derived by :meth:`KernelSpec.from_scene`): ``DEFECTS_OUTER``,
``DEFECTS_INNER``, ``DEFECTS_BALL`` (a spall on that surface), ``UNBALANCE`` (a load turning
with the inner ring), ``LOAD_TABLE`` (F_r changing in time) and ``OUT_OF_ROUND`` (a lobed outer
race). A healthy scene sets none, and its kernel is the one without them.
"""

from __future__ import annotations

from dataclasses import dataclass

from signatelec.config.options import OPTIONS, Option
from signatelec.config.scene import Scene

KERNEL_OPTIONS: tuple[Option, ...] = tuple(o for o in OPTIONS if o.kernel)
#: Flags the scene's defects and abnormal loads set (module docstring).
SCENE_FLAGS = (
    "DEFECTS_OUTER",
    "DEFECTS_INNER",
    "DEFECTS_BALL",
    "UNBALANCE",
    "LOAD_TABLE",
    "OUT_OF_ROUND",
)


def scene_flags(scene: Scene) -> tuple[tuple[str, bool], ...]:
    """(flag, on) of :data:`SCENE_FLAGS` for ``scene``."""
    where = {d.location for d in scene.defects}
    on = {
        "DEFECTS_OUTER": "outer" in where,
        "DEFECTS_INNER": "inner" in where,
        "DEFECTS_BALL": "ball" in where,
        "UNBALANCE": scene.loads.unbalance_amplitude_n(scene.operating.omega_rad_s) > 0.0,
        "LOAD_TABLE": scene.loads.has_table,
        "OUT_OF_ROUND": scene.housing.out_of_round,
    }
    return tuple((name, on[name]) for name in SCENE_FLAGS)


def flag_name(option: Option, value) -> str:
    """The kernel's boolean for ``option`` taking ``value`` (the option's own for a switch)."""
    return option.name.upper() if option.switch else f"{option.name}_{value}".upper()


@dataclass(frozen=True)
class KernelSpec:
    """((option, value), ...) of every kernel option, in :data:`KERNEL_OPTIONS` order, and
    ((flag, on), ...) of the :data:`SCENE_FLAGS`."""

    choices: tuple[tuple[str, str | bool], ...]
    scene: tuple[tuple[str, bool], ...] = tuple((name, False) for name in SCENE_FLAGS)

    def __post_init__(self) -> None:
        names = tuple(name for name, _ in self.choices)
        expected = tuple(o.name for o in KERNEL_OPTIONS)
        if names != expected:
            raise ValueError(f"KernelSpec options {names}: must be {expected}")
        for option, (_, value) in zip(KERNEL_OPTIONS, self.choices, strict=True):
            if value not in option.values or type(value) is not type(option.default):
                raise ValueError(f"KernelSpec {option.name} = {value!r}: {option.rule}")
        if tuple(name for name, _ in self.scene) != SCENE_FLAGS or not all(
            isinstance(on, bool) for _, on in self.scene
        ):
            raise ValueError(f"KernelSpec scene flags {self.scene}: must be {SCENE_FLAGS}")

    @classmethod
    def from_scene(cls, scene: Scene) -> KernelSpec:
        """The kernel ``scene`` runs. Choices that compile to the same code share one kernel:
        Harris' law is Hertz's delta^{3/2} with other coefficients (eqs 10-11), a friction
        coefficient of 0 is no friction, and without friction the tangential model is unused."""
        values = {o.name: getattr(getattr(scene, o.section), o.name) for o in KERNEL_OPTIONS}
        if values["contact_law"] == "harris":
            values["contact_law"] = "hertz"
        if scene.bearing.friction_coefficient <= 0.0:
            values["friction"] = "none"
        if values["friction"] == "none":
            values["tangential"] = _default("tangential")
        return cls(tuple(values.items()), scene_flags(scene))

    @classmethod
    def default(cls) -> KernelSpec:
        """The seed scene's kernel."""
        return cls.from_scene(Scene())

    def __getitem__(self, name: str) -> str | bool:
        return dict(self.choices)[name]

    def flags(self) -> dict[str, bool]:
        """Every boolean the kernel source may read, by name."""
        out = {}
        for option, (_, chosen) in zip(KERNEL_OPTIONS, self.choices, strict=True):
            if option.switch:
                out[flag_name(option, chosen)] = chosen
            else:
                for value in option.values:
                    out[flag_name(option, value)] = chosen == value
        return out | dict(self.scene)

    @property
    def key(self) -> str:
        """Short readable name, e.g. ``balls-coulomb-critical-hertz-seed-standard-inertial-
        verlet`` (switches appear by name when on)."""
        parts = []
        for option, (_, value) in zip(KERNEL_OPTIONS, self.choices, strict=True):
            if option.switch:
                if value:
                    parts.append(option.name)
            else:
                parts.append(str(value))
        parts += [name.lower() for name, on in self.scene if on]
        return "-".join(parts)


def _default(name: str):
    return next(o.default for o in KERNEL_OPTIONS if o.name == name)
