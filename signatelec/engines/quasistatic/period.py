"""The quasi-static tier over one ball-pass period, solved once and mapped onto every instant.

For a healthy bearing under a static load the tier's steady state depends on the cage angle
alone: ball k sits at ``theta_c + 2 pi k / Z`` and the loads, the speed and the contact laws do
not change with time, so the state at ``theta_c + 2 pi / Z`` is the state at ``theta_c`` with
every ball moved one slot on. :class:`PeriodMap` solves the tier's equations
(:func:`signatelec.engines.quasistatic.tier.instant_columns`: equilibrium, electrical network)
on a grid of :data:`PERIOD_NODES` intervals of one ball-pass period, once, and maps each recorded
instant onto it: ball k at an instant is slot ``(k + m) mod Z`` of the grid, m the whole ball
passes since the reference, interpolated by the cubic through the four nodes around its
fraction of the period. Its cost per instant is a few reads per value, whatever the duration (the
grid, about 4 MB, stays in the processor's cache: a grid 4 times finer read by linear
interpolation cost 3 times more, from memory).

The cubic errs by ``h^4 max|f''''| / 24`` at most where the columns are smooth (h = 2 pi / (Z
PERIOD_NODES) = 1.2e-4 rad for the seed's bearing). Where a contact
opens or closes within the stencil the columns are not smooth (Hertz: force ~ delta^{3/2}, the
contact radius and a ball's conductance ~ delta^{1/2}, Hamrock-Brewe and seed eq. 16), so the
instants within :data:`SMOOTH_MARGIN` grid intervals of a change of the contact pattern are
solved one by one, as the per-instant tier does (0.5 % of them for the seed's scene), each
Newton started from the instant's interpolated ring shift. The
columns that are a maximum or a count over the balls (largest ball load, loaded balls, largest
current density) are formed at each instant from the interpolated ball columns, not
interpolated themselves (a maximum has a kink where the largest ball changes). The tables agree
with the per-instant solution to 1e-6 of each column's largest value
(tests/test_streaming.py). The tables' arrays are carved from memory freed by earlier tables
(:mod:`signatelec.engines.quasistatic.buffers`): written over, not faulted in and zeroed anew.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from signatelec.config.scene import Scene
from signatelec.engines.quasistatic.buffers import table_arrays
from signatelec.engines.results import PHASES
from signatelec.physics.electrical import max_current_density_a_m2
from signatelec.physics.load_distribution import epsilon_from_shift

#: Intervals of the grid over one ball-pass period.
PERIOD_NODES = 4096
#: Grid intervals each side of a change of the contact pattern whose instants are solved one by
#: one. Measured on the seed's scene (largest error over the columns, relative to each column's
#: largest value; the ring's horizontal shift, 0.5 % of its vertical one, is the worst): 4.4e-7
#: at 1024 nodes and 4 intervals, 1.5e-7 at 2048 and 4, 6.1e-8 at 4096 and 8 (the per-instant
#: solution's own scatter, from the solver's tolerance, is 4e-8 on that column). At 4096 nodes,
#: over the four scenes of tests/test_streaming.py (the worst, 2.4e-7, is the preloaded scene's
#: horizontal shift, the solver's scatter whatever the margin): 2.4e-7 at 8 and 6 intervals and
#: at 5 (its instants solved one by one: 0.54 % against 0.83 % at 8), 3.6e-7 at 4, 1.7e-6 at 2.
SMOOTH_MARGIN = 5
#: Steady instants from which the map pays: its grid costs about as many instants solved.
MIN_INSTANTS = 2 * (PERIOD_NODES + 2 * SMOOTH_MARGIN)
#: Columns formed at each instant from the others rather than interpolated.
_DERIVED = ("loaded_balls", "max_ball_load_n", "max_current_density_a_m2", "delta_r_m", "epsilon")


def ball_pass_periodic(scene: Scene) -> bool:
    """Whether ``scene``'s quasi-static steady state is a function of the cage angle alone,
    periodic with one ball-pass period 2 pi / Z: balls alike and evenly spaced (the tier's
    kinematics), a load fixed in magnitude and direction, a constant speed in the steady phase.

    A defect on a race or a ball, a rotating or tabulated load or an out-of-round ring
    (:attr:`~signatelec.config.scene.Scene.abnormal`) breaks it: the tier then solves per instant.
    """
    return not scene.abnormal


def use_period_map(scene: Scene, n_instants: int) -> bool:
    """Whether the tier maps ``n_instants`` steady instants onto one period: a periodic scene
    and enough instants for the grid to pay."""
    return ball_pass_periodic(scene) and n_instants >= MIN_INSTANTS


def ball_angles_rad(cage_angle_rad, n_balls: int) -> np.ndarray:
    """Angles (T, Z) of evenly spaced balls, ball 0 at ``cage_angle_rad`` (T,), from -y
    counter-clockwise, in (-pi, pi]."""
    psi = np.asarray(cage_angle_rad)[:, None] + 2.0 * math.pi * np.arange(n_balls) / n_balls
    return math.pi - np.remainder(math.pi - psi, 2.0 * math.pi)


class PeriodMap:
    """One ball-pass period of ``scene``'s quasi-static state, solved on a grid, and the map of
    recorded instants onto it (see the module docstring).

    ``solve(scene, t, psi)`` gives the tables' columns of the state at ball angles ``psi`` (T, Z)
    solved instant by instant (:func:`signatelec.engines.quasistatic.tier.instant_columns`);
    ``cage_angle_rad(scene, t)`` the angle of ball 0 at the instants ``t``.
    """

    def __init__(self, scene: Scene, solve, cage_angle_rad):
        self.scene = scene
        self.solve, self.cage_angle_rad = solve, cage_angle_rad
        z = scene.bearing.n_balls
        self.period_rad = 2.0 * math.pi / z
        self.theta_ref_rad = scene.operating.initial_ball_angle_rad
        n, w = PERIOD_NODES, SMOOTH_MARGIN
        fraction = np.arange(-w, n + w + 1) / n
        psi = ball_angles_rad(self.theta_ref_rad + fraction * self.period_rad, z)
        balls, signals, self.spent = solve(scene, np.zeros(fraction.size), psi)
        self.ball_order, self.signal_order = list(balls), list(signals)
        shape = (fraction.size, z)
        self.ball_constants, self.signal_constants = {}, {}
        mapped_b, mapped_s = [], []
        for name, values in balls.items():
            if name in ("time_s", "ball", "angle_rad"):
                continue
            if _constant(values) and name != "inner_force_n":  # the kernel reads that one
                self.ball_constants[name] = values[0]
            else:
                mapped_b.append((name, values.reshape(shape)))
        for name, values in signals.items():
            if name in ("time_s", "phase", *_DERIVED):
                continue
            if _constant(values):
                self.signal_constants[name] = values[0]
            else:
                mapped_s.append((name, np.asarray(values)))
        inner = balls["inner_force_n"].reshape(shape)
        # each ball's largest current density (the instant's is their maximum, electrical.py),
        # read but not written out: [node, slot], no slot without the electrical network
        self.grid_density = np.zeros((fraction.size, 0))
        if "current_a" in balls:
            current = balls["current_a"].reshape(-1, 1)
            self.grid_density = np.maximum(
                max_current_density_a_m2(current, balls["inner_area_m2"].reshape(-1, 1)),
                max_current_density_a_m2(current, balls["outer_area_m2"].reshape(-1, 1)),
            ).reshape(shape)
        self.ball_names = [name for name, _ in mapped_b]
        self.signal_names = [name for name, _ in mapped_s]
        # [node, slot, column]: an instant reads each node's values in one contiguous stretch,
        # the very order of its rows in the output
        self.grid_ball = np.ascontiguousarray(np.stack([v for _, v in mapped_b], axis=-1))
        self.grid_signal = np.zeros((fraction.size, len(mapped_s)))
        for c, (_, values) in enumerate(mapped_s):
            self.grid_signal[:, c] = values
        # the contact pattern (and where a value is missing) at each node; an interval is
        # smooth when it holds within SMOOTH_MARGIN intervals on either side
        pattern = np.concatenate(
            [
                inner > 0.0,
                balls["outer_force_n"].reshape(shape) > 0.0,
                np.isnan(self.grid_ball).reshape(fraction.size, -1),
                np.isnan(self.grid_density),
                ~np.isfinite(self.grid_signal),
            ],
            axis=1,
        )
        change = np.any(pattern[1:] != pattern[:-1], axis=1)
        csum = np.concatenate([[0], np.cumsum(change)])
        j = np.arange(n)
        # interval j (its cubic stencil: nodes j - 1 .. j + 2) is smooth when no change of the
        # pattern lies between nodes j - w and j + w + 1 (rows j .. j + 2 w + 1)
        self.rough = (csum[j + 2 * w + 1] - csum[j]) > 0
        self.compile_s = 0.0
        if not _map_instants.signatures:
            t0 = time.perf_counter()
            self._map(np.zeros(1))
            self.compile_s = time.perf_counter() - t0

    def describe(self) -> dict:
        return {
            "nodes": PERIOD_NODES,
            "period_rad": self.period_rad,
            "rough_fraction": float(self.rough.mean()),
        }

    def _map(self, t: np.ndarray):
        z = self.scene.bearing.n_balls
        n_rec = t.size
        theta = self.cage_angle_rad(self.scene, t)
        n_rows = n_rec * z
        # [row, column]: an instant's values are written in one stretch (the tables take the
        # columns as strided views); the tables' memory is that of the last ones freed
        out_ball, time_rows, angle, out_signal, largest, delta_r, node, ball_rows, loaded, phase = (
            table_arrays(
                [((n_rows, len(self.ball_names)), float), ((n_rows,), float), ((n_rows,), float)]
                + [((len(self.signal_names), n_rec), float), ((2, n_rec), float)]
                + [((n_rec,), float), ((n_rec,), np.int64), ((n_rows,), np.int32)]
                + [((n_rec,), np.int32), ((n_rec,), np.int8)]
            )
        )
        _map_instants(
            theta,
            t,
            self.theta_ref_rad,
            self.period_rad,
            PERIOD_NODES,
            SMOOTH_MARGIN,
            self.grid_ball,
            self.grid_density,
            self.grid_signal,
            self.ball_names.index("inner_force_n"),
            out_ball,
            out_signal,
            time_rows,
            ball_rows,
            angle,
            loaded,
            largest,
            node,
        )
        phase[:] = PHASES.index("steady")  # delta_r: written by columns()
        tables = out_ball, out_signal, time_rows, ball_rows, angle, loaded, largest, delta_r, phase
        return *tables, node

    def columns(self, t) -> tuple[dict, dict, dict]:
        """The tables' columns at the instants ``t`` (as
        :func:`~signatelec.engines.quasistatic.tier.instant_columns`) and the time spent."""
        t0 = time.perf_counter()
        t = np.ascontiguousarray(t, dtype=float)
        z = self.scene.bearing.n_balls
        n_rec = t.size
        out_ball, out_signal, time_rows, ball_rows, angle, loaded, largest, delta_r, phase, node = (
            self._map(t)
        )
        mapped_b = dict(zip(self.ball_names, out_ball.T, strict=True))
        mapped_s = dict(zip(self.signal_names, out_signal, strict=True))
        derived = {
            "loaded_balls": loaded,
            "max_ball_load_n": largest[0],
            "max_current_density_a_m2": largest[1],
        }
        balls = {}
        for name in self.ball_order:
            if name == "time_s":
                balls[name] = time_rows
            elif name == "ball":
                balls[name] = ball_rows
            elif name == "angle_rad":
                balls[name] = angle
            elif name in self.ball_constants:
                balls[name] = _full(n_rec * z, self.ball_constants[name])
            else:
                balls[name] = mapped_b[name]
        signals = {}
        for name in self.signal_order:
            if name == "time_s":
                signals[name] = t
            elif name == "phase":
                signals[name] = phase
            elif name == "delta_r_m":
                signals[name] = np.hypot(signals["inner_x_m"], signals["inner_y_m"], out=delta_r)
            elif name == "epsilon":
                clearance = self.scene.operating.clearance_m
                signals[name] = epsilon_from_shift(signals["delta_r_m"], clearance)
            elif name in derived:
                signals[name] = derived[name]
            elif name in self.signal_constants:
                signals[name] = _full(n_rec, self.signal_constants[name])
            else:
                signals[name] = mapped_s[name]
        spent = {"map_s": time.perf_counter() - t0}
        rough = np.flatnonzero(self.rough[node])
        if rough.size:
            # near a contact that opens or closes: the tier's own per-instant solution, each
            # instant's Newton started from its interpolated shift (one or two steps)
            psi = ball_angles_rad(self.cage_angle_rad(self.scene, t[rough]), z)
            start = np.stack([signals["inner_x_m"][rough], signals["inner_y_m"][rough]], axis=1)
            exact_b, exact_s, exact_spent = self.solve(self.scene, t[rough], psi, start)
            rows = (rough[:, None] * z + np.arange(z)).ravel()
            # the constant columns hold the same constant there (read-only, not written)
            for name, values in exact_b.items():
                if name not in self.ball_constants:
                    balls[name][rows] = values
            for name, values in exact_s.items():
                if name != "phase" and name not in self.signal_constants:
                    signals[name][rough] = values
            for key, value in exact_spent.items():
                spent[key] = spent.get(key, 0.0) + value
        return balls, signals, spent


def _constant(values) -> bool:
    values = np.asarray(values)
    return values.size > 0 and bool(
        np.all(values == values[0]) or np.all(np.isnan(values.astype(float)))
    )


def _full(n: int, value) -> np.ndarray:
    """A column holding ``value`` at every row: one value read-only repeated (stride 0), not n
    written (the tier's kinematic speeds and zero tangential forces are constant by
    construction; a table column is read, pandas copies before it writes)."""
    return np.broadcast_to(np.asarray(value, dtype=float), (n,))


@njit(cache=True, error_model="numpy")
def _map_instants(
    theta, t, theta_ref, period, n, margin, grid_ball, grid_density, grid_signal, inner_col,
    out_ball, out_signal, time_rows, ball_rows, angle, loaded, largest, node,
):  # fmt: skip
    """Interpolate the grid at each instant of cage angle ``theta`` (see PeriodMap) into
    ``out_ball`` [row, column] and ``out_signal`` [column, instant], with each row's time, ball
    and angle; the loaded balls and the largest inner force over the balls (from the ball column
    ``inner_col``) and the largest of each ball's current density (``grid_density``, read, not
    written out; no slot: none)."""
    z, n_col = grid_ball.shape[1], grid_ball.shape[2]
    width = z * n_col
    # an instant's rows are one stretch of the output, its slots one stretch of each node
    grid = grid_ball.reshape((grid_ball.shape[0], width))
    out = out_ball.reshape((theta.shape[0], width))
    two_pi = 2.0 * math.pi
    step = two_pi / z
    for i in range(theta.shape[0]):
        u = (theta[i] - theta_ref) / period
        m = math.floor(u)
        pos = (u - m) * n
        j = min(int(math.floor(pos)), n - 1)
        x = pos - j
        node[i] = j
        # Lagrange weights of the nodes j - 1 .. j + 2 (the grid starts ``margin`` nodes early)
        w0 = -x * (x - 1.0) * (x - 2.0) / 6.0
        w1 = (x + 1.0) * (x - 1.0) * (x - 2.0) / 2.0
        w2 = -(x + 1.0) * x * (x - 2.0) / 2.0
        w3 = (x + 1.0) * x * (x - 1.0) / 6.0
        a = j + margin - 1
        for c in range(grid_signal.shape[1]):
            g0, g1 = grid_signal[a, c], grid_signal[a + 1, c]
            g2, g3 = grid_signal[a + 2, c], grid_signal[a + 3, c]
            if g0 == g1 and g1 == g2 and g2 == g3:  # an infinite resistance stays one
                out_signal[c, i] = g1
            else:
                out_signal[c, i] = w0 * g0 + w1 * g1 + w2 * g2 + w3 * g3
        # ball k is slot (k + shift) mod z: the slots from ``shift`` on, then those before it
        # (ball columns are finite or NaN, a potential out of the circuit: no inf)
        cut = int(m) % z * n_col  # whole ball passes since the reference, in integers
        row = out[i]
        _weigh(row[: width - cut], grid, a, cut, width, w0, w1, w2, w3)
        _weigh(row[width - cut :], grid, a, 0, cut, w0, w1, w2, w3)
        n_loaded = 0
        largest_load = 0.0
        # ball 0's angle in (-pi, pi], then each next ball one pitch on, wrapped once (the
        # remainder by a division: a floating-point modulo of a large angle costs more)
        turns = math.floor((math.pi - theta[i]) / two_pi)
        first = theta[i] + turns * two_pi
        if first <= -math.pi:
            first += two_pi
        elif first > math.pi:
            first -= two_pi
        for k in range(z):
            r = i * z + k
            time_rows[r] = t[i]
            ball_rows[r] = k
            psi = first + step * k
            angle[r] = psi - two_pi if psi > math.pi else psi
            load = row[k * n_col + inner_col]
            n_loaded += load > 0.0
            largest_load = max(largest_load, load)
        largest_density = 0.0
        for s in range(grid_density.shape[1]):
            density = (
                w0 * grid_density[a, s]
                + w1 * grid_density[a + 1, s]
                + w2 * grid_density[a + 2, s]
                + w3 * grid_density[a + 3, s]
            )
            largest_density = max(largest_density, density)
        loaded[i] = n_loaded
        largest[0, i] = largest_load
        largest[1, i] = largest_density


@njit(inline="always")
def _weigh(out, grid, a, start, stop, w0, w1, w2, w3):
    """``out`` = the cubic's weights on ``grid``'s nodes a .. a + 3 over the stretch ``start`` ..
    ``stop`` of each, element by element: one loop whose indices numba knows are not negative
    (no wrap-around test), which the compiler vectorises."""
    g0, g1 = grid[a, start:stop], grid[a + 1, start:stop]
    g2, g3 = grid[a + 2, start:stop], grid[a + 3, start:stop]
    for q in range(out.shape[0]):
        out[q] = w0 * g0[q] + w1 * g1[q] + w2 * g2[q] + w3 * g3[q]
