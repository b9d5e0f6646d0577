"""Localised defects and abnormal loads of a scene: ``[[defects]]``, ``[loads]``, ``[housing]``.

A :class:`Defect` is a spall on a raceway or a ball, given by its centre, its length along the
surface and its depth, with an edge profile; the DEM and the quasi-static tier take it as
geometry (the contact overlap is measured to the local surface, signatelec.physics.defects), not
as an added force. :class:`Loads` adds a load rotating with the inner ring (unbalance) and a
radial load that changes in time; :class:`Housing` makes the outer race out of round.

Angle conventions (every angle counter-clockwise, like the balls' angles):

- ``location = "outer"``: ``angle_rad`` from the load direction -y, fixed in space;
- ``"inner"``: on the inner ring at t = 0, turning with it (ring angle + ``angle_rad``);
- ``"ball"``: on ball ``ball``'s surface at t = 0, from -y, turning with its spin (its rotation
  angle + ``angle_rad``).

TOML::

    [[defects]]                 # an array of tables: several defects per scene
    location = "outer"          # "outer" | "inner" | "ball"
    angle_rad = 0.0
    length_m = 1.5e-3           # along the surface
    depth_m = 50e-6
    ball = 0                    # location = "ball" only
    profile = "rectangular"     # "rectangular" | "smooth"

    [loads]
    unbalance_force_n = 200.0   # or unbalance_mass_kg and unbalance_eccentricity_m (m e omega^2)
    unbalance_phase_rad = 0.0   # direction at t = 0, from -y; turns with the inner ring
    load_table_time_s = [0.01, 0.0101]          # after the set-up
    load_table_radial_load_n = [5820.0, 8000.0] # F_r, linear between points

    [housing]
    out_of_round_lobes = 3      # R_out(theta) = R_out + A cos(n theta), theta from -y
    out_of_round_amplitude_m = 5e-6

The rows below (:data:`DEFECT`, :data:`DEFECT_LIMITS`, :data:`ABNORMAL`, :data:`TABLE`, in the
form of :mod:`signatelec.config.constraints`) say what is allowed; the checks that need the
bearing or the rest of the scene (a length shorter than its surface, a ball index in range,
loads within the scene's limit) are applied by :func:`signatelec.config.scene.validate_scene`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from signatelec.config.constraints import (
    CHOICE,
    DURATION_MAX_S,
    INTEGER,
    NUMBER,
    OVERLAP_LIMIT_FRACTION,
    Checker,
    Constraint,
    Limit,
    row_of,
)

LOCATIONS = ("outer", "inner", "ball")
PROFILES = ("rectangular", "smooth")
#: Most defects a scene may hold (the kernel's parameter record has room for as many).
MAX_DEFECTS = 8
#: Deepest spall, as a fraction of the ball radius (spalls are tens to hundreds of microns deep).
DEPTH_LIMIT_FRACTION = 0.1
#: Most points of a load table (the kernel's parameter record has room for as many).
MAX_LOAD_TABLE_POINTS = 64
MAX_LOBES = 64

_POSITIVE = "must be a finite number > 0"

#: The keys of one ``[[defects]]`` table (the rows of signatelec.config.constraints' kind).
DEFECT = (
    Constraint("defects", "location", CHOICE, choices=LOCATIONS),
    Constraint("defects", "angle_rad", NUMBER),
    Constraint("defects", "length_m", NUMBER, low=0.0, low_open=True, allowed=_POSITIVE),
    Constraint("defects", "depth_m", NUMBER, low=0.0, low_open=True, allowed=_POSITIVE),
    Constraint("defects", "ball", INTEGER, low=0, allowed="must be an integer >= 0"),
    Constraint("defects", "profile", CHOICE, choices=PROFILES),
)
#: The limits of a defect that need the bearing (its surface, the number of balls).
DEFECT_LIMITS = (
    Constraint(
        "defects",
        "length_m",
        NUMBER,
        high=Limit("surface_length_m"),
        high_open=True,
        allowed="must be shorter than the circumference of the {surface} ({high:.4g} m)",
    ),
    Constraint(
        "defects",
        "depth_m",
        NUMBER,
        high=Limit("depth_limit_m"),
        allowed=f"must be <= {{high:.3g}} m ({100 * DEPTH_LIMIT_FRACTION:g} % of the ball radius)",
    ),
    Constraint(
        "defects", "ball", INTEGER, high=Limit("last_ball"), allowed="must be a ball in [0, {high}]"
    ),
)
#: Ranges and rules of [loads] and [housing]; the load table is checked element by element.
ABNORMAL = (
    *(
        Constraint("loads", key, NUMBER, low=0.0, allowed="must be >= 0")
        for key in ("unbalance_force_n", "unbalance_mass_kg", "unbalance_eccentricity_m")
    ),
    Constraint(
        "loads",
        "unbalance_force_n",
        NUMBER,
        rule=Limit("one_unbalance_form"),
        allowed="give unbalance_force_n or unbalance_mass_kg and unbalance_eccentricity_m, "
        "not both",
    ),
    Constraint(
        "loads",
        "unbalance_force_n",
        NUMBER,
        rule=Limit("unbalance_within_limit"),
        allowed="the unbalance ({unbalance_n:.4g} N at omega) plus the largest F_r "
        "({largest_load_n:.4g} N) must be <= {radial_load_limit_n:.4g} N (Stribeck's largest "
        f"ball load would overlap a raceway by more than {100 * OVERLAP_LIMIT_FRACTION:g} % of "
        "the ball radius)",
    ),
    Constraint("housing", "out_of_round_lobes", INTEGER, 0, MAX_LOBES),
    Constraint(
        "housing",
        "out_of_round_amplitude_m",
        NUMBER,
        low=0.0,
        high=Limit("clearance_limit_m"),
        allowed="must be in [0, {high:.3g}] m (the clearance limit)",
    ),
    Constraint(
        "housing",
        "out_of_round_amplitude_m",
        NUMBER,
        rule=Limit("lobes_given"),
        allowed="an out-of-round ring needs out_of_round_lobes >= 1",
    ),
)
#: One element of the load table.
TABLE = (
    Constraint("loads", "load_table_time_s", NUMBER, 0.0, DURATION_MAX_S),
    Constraint(
        "loads",
        "load_table_radial_load_n",
        NUMBER,
        low=0.0,
        high=Limit("radial_load_limit_n"),
        allowed="must be in [0, {high:.4g}] N (the scene's radial load limit)",
    ),
)


@dataclass(frozen=True, kw_only=True)
class Defect:
    """A spall: a pit of ``length_m`` (along the surface) by ``depth_m``, centred at
    ``angle_rad`` (conventions in the module docstring), with a ``profile`` of its edges."""

    location: str
    angle_rad: float = 0.0
    length_m: float
    depth_m: float
    ball: int = 0
    profile: str = "rectangular"

    @classmethod
    def from_dict(cls, data: Any, where: str, error: type[Exception]) -> Defect:
        """A defect from its TOML table; ``where`` names it in messages (``defects[0]``)."""
        check = Checker(error)
        table = check.table(where, data)
        known = [f.name for f in fields(cls)]
        check.keys(where, table, known)
        for key in ("location", "length_m", "depth_m"):
            if key not in table:
                check.fail(where, table, f"{key} is required")
        values = {
            key: check.check(row_of(DEFECT, "defects", key), table[key], f"{where}.{key}")
            for key in known
            if key in table
        }
        return cls(**values)


@dataclass(frozen=True)
class Loads:
    """Loads besides the static F_r of [operating]: an unbalance and a load table."""

    #: Amplitude of a load turning with the inner ring at shaft speed (unbalance), N, at the
    #: operating speed; during the spin-up it grows as omega^2 like a mass unbalance's.
    unbalance_force_n: float = 0.0
    #: The same load given as a mass and its eccentricity: m e omega^2 (give one form only).
    unbalance_mass_kg: float = 0.0
    unbalance_eccentricity_m: float = 0.0
    #: Direction of the unbalance at t = 0, from the load direction -y, rad.
    unbalance_phase_rad: float = 0.0
    #: Times after the set-up (s), increasing, and F_r there (N): linear between points, the
    #: operating radial_load_n before the first, the last value after it. Empty: constant F_r.
    load_table_time_s: tuple = ()
    load_table_radial_load_n: tuple = ()

    def __post_init__(self) -> None:
        for name in ("load_table_time_s", "load_table_radial_load_n"):
            value = getattr(self, name)
            if isinstance(value, list):  # TOML arrays; elements are checked by the scene
                object.__setattr__(self, name, tuple(value))

    def unbalance_amplitude_n(self, omega_rad_s: float) -> float:
        """The unbalance force at ``omega_rad_s``, N (the force, else m e omega^2)."""
        if self.unbalance_force_n > 0.0:
            return float(self.unbalance_force_n)
        return float(self.unbalance_mass_kg * self.unbalance_eccentricity_m * omega_rad_s**2)

    @property
    def has_table(self) -> bool:
        return len(self.load_table_time_s) > 0


@dataclass(frozen=True)
class Housing:
    """An out-of-round outer ring: R_out(theta) = R_out + A cos(n theta), theta from -y."""

    out_of_round_lobes: int = 0
    out_of_round_amplitude_m: float = 0.0

    @property
    def out_of_round(self) -> bool:
        return self.out_of_round_lobes > 0 and self.out_of_round_amplitude_m != 0.0
