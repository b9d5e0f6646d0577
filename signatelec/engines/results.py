"""What every engine returns: the set-up phases and the result tables of a run.

Both engines (the DEM in :mod:`signatelec.engines.dem` and the quasi-static tier in
:mod:`signatelec.engines.quasistatic`) return a :class:`SimulationResult` with the same columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from signatelec.config.scene import Scene

if TYPE_CHECKING:  # a streamed run never builds a DataFrame: pandas is imported where used
    import pandas as pd


class DivergenceError(RuntimeError):
    """A run left the physical range; the message names the step, body and quantity."""


PHASES = ("clearance", "load", "spin_up", "steady")
#: A ball counts as loaded above this inner-raceway force; below it the force is round-off of a
#: contact at its onset (a Hertz overlap of ~1e-11 m).
LOADED_FORCE_N = 1e-6
#: Smallest inner-ring shift for which the load parameter of eq. 15 is reported.
MIN_SHIFT_M = 1e-9


def to_frame(columns: dict, copy: bool = True) -> pd.DataFrame:
    """A table given as numpy columns (``phase``, when there, as codes into :data:`PHASES`) as
    the DataFrame a result holds (``phase`` categorical; ``copy=False``: the arrays themselves,
    for columns made for the table alone)."""
    import pandas as pd

    data = dict(columns)
    if "phase" in data and not isinstance(data["phase"], pd.Categorical):
        data["phase"] = pd.Categorical.from_codes(data["phase"], PHASES)
    return pd.DataFrame(data, copy=copy)


def phase_times(scene: Scene) -> tuple[float, float, float]:
    """Ends of the clearance, load and spin-up phases, s (a phase that is off has length 0)."""
    pr = scene.procedure
    t1 = pr.clearance_time_s if pr.clearance_phase else 0.0
    t2 = t1 + (pr.load_time_s if pr.load_ramp == "smooth" else 0.0)
    t3 = t2 + (pr.spin_up_time_s if pr.spin_up else 0.0)
    if pr.load_ramp == "step":
        # the load still waits for its phase, then comes at once
        t2 = t1
    return t1, t2, t3


def in_steady_phase(time_s, scene: Scene, settle_s: float = 0.0):
    """Whether each recorded instant of ``time_s`` (an array or a Series) lies in the steady
    phase of a run of ``scene``, from ``settle_s`` after the set-up ends (an instant recorded at
    the set-up's end, within rounding, belongs to the set-up)."""
    return time_s > scene.setup_time_s + settle_s + 1e-12


def record_rate_hz(scene: Scene) -> float:
    """The rate a run of ``scene`` records at, Hz: an instant every ``scene.record_every`` steps.
    It is ``numerics.sample_rate_hz`` when dt divides the record period a whole number of times
    (the automatic and the presets' steps do:
    :func:`~signatelec.physics.stability.record_grid_dt_s`); a step given off that grid records
    at the nearest whole number of steps (dt = 1.366e-6 s at 20 kHz: 19782 Hz)."""
    return 1.0 / (scene.record_every * scene.numerics.dt_s)


@dataclass
class SimulationResult:
    """Outcome of :func:`simulate`: the scene, tables of balls and signals, timings.

    A run streamed to a directory (``simulate(scene, out_dir=...)``) holds no tables
    (``balls`` and ``signals`` are None): they are in ``out_dir``, and :attr:`steady_signal_means`
    holds the steady-phase means of the signal columns gathered on the way.
    """

    scene: Scene
    balls: pd.DataFrame | None
    signals: pd.DataFrame | None
    timings: dict = field(default_factory=dict)
    stability: object | None = None  # physics.stability.StabilityLimit for a DEM run
    out_dir: Path | None = None
    steady_signal_means: dict | None = None
    #: The warnings this scene's own run gave (``warnings.WarningMessage``), filled by
    #: :func:`~signatelec.engines.dem.batch.simulate_batch`, whose scenes run together so that
    #: catching warnings around the call cannot tell whose each one is; empty otherwise (a
    #: single run's warnings are the ones raised during the call).
    warnings: list = field(default_factory=list)

    def steady(self, table: str = "signals", settle_s: float = 0.0) -> pd.DataFrame:
        """Rows of the steady-running phase, from ``settle_s`` after the set-up ends."""
        df = self._table(table)
        return df[in_steady_phase(df["time_s"], self.scene, settle_s)]

    def steady_means(self) -> dict[str, float]:
        """Mean of each numeric signal column over the steady phase (NaN skipped)."""
        if self.signals is None:
            return dict(self.steady_signal_means or {})
        return self.steady().drop(columns="phase").mean().to_dict()

    def write(self, out_dir) -> None:
        from signatelec.io import write_result

        self._table("balls")
        write_result(self, out_dir)

    def _table(self, name: str) -> pd.DataFrame:
        df = getattr(self, name)
        if df is None:
            raise ValueError(f"this run was streamed to {self.out_dir}: read {name}.parquet there")
        return df
