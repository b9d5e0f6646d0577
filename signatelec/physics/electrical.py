"""Electrical resistance of a ball bearing from its contact forces (seed section 3, eqs 16-18).

The seed's electrical model: every steel ball is a conductor between its contact ellipses (eq. 16),
the ellipses follow from the normal forces by Hertz theory in the Hamrock-Brewe approximation
(eqs 17-18; both in :mod:`signatelec.physics.conductance`), the rings are perfect conductors, the
polyamide cage balls insulate, and a current ``I`` injected into the outer ring leaves through the
inner ring held at 0 V (Kirchhoff's first law and Ohm's law). The bearing resistance is
``V_outer / I``. This module builds and solves that network.

Shapes and indexing (``T`` recorded instants, ``Z`` rolling balls)
-------------------------------------------------------------------
- ``inner_force_n``, ``outer_force_n``: shape (n_instants, n_balls), ``[t, k]``, normal force (N) of
  ball ``k`` on the inner / outer raceway; <= 0 means no contact.
- ``ball_ball_force_n``: shape (n_instants, n_balls), ``[t, k]``, force between ball ``k`` and ball
  ``(k + 1) % Z`` (only when the cage is off), or ``None``.
- ``ball_xy_m``: shape (n_instants, n_balls, 2), ``[t, k, xy]``, ball centres, outer-ring centre at
  the origin; ``inner_ring_xy_m``: shape (n_instants, 2), ``[t, xy]``.
- :class:`ElectricalResult`: ``resistance_ohm`` and ``max_current_density_a_m2`` shape
  (n_instants,); ``current_a``, ``potential_v``, ``inner_area_m2``, ``outer_area_m2`` shape
  (n_instants, n_balls).

Network nodes: ``OUTER_RING_NODE = 0`` (current injected), ``INNER_RING_NODE = 1`` (grounded), then
one node per ball/ball contact point. Each ball joins every pair of its conducting contacts by the
conductance of eq. 16.

Two solvers give the same answer where both apply (``tests/test_electrical.py`` checks it to
1e-10): with no ball/ball contact at an instant every ball is a conductance between the two rings
and the network is a parallel sum, vectorised over instants; otherwise the weighted Laplacian of
the instants concerned is assembled as one block-diagonal ``scipy.sparse`` matrix, reduced to the
connected component joining the rings and solved with ``spsolve``.

References
----------
Seed: C. Machado, M. Guessasma, E. Bellenger, *Modelling of ball bearing loading by DEM for
electromechanical coupling*, section 3, eqs 16-18 (the contact ellipses' references are in
:mod:`signatelec.physics.conductance`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from signatelec.config.bearing import Bearing
from signatelec.physics.conductance import ball_conductance, bearing_contact_area

OUTER_RING_NODE = 0
INNER_RING_NODE = 1
#: Seed section 3: a current density above 0.1 A/mm^2 harms raceways (its refs 8-9).
DENSITY_LIMIT_A_M2 = 1e5


class CurrentDensityWarning(UserWarning):
    """A contact carries more current per unit area than the seed's 0.1 A/mm^2 harm threshold."""


# --- Kirchhoff network ----------------------------------------------------------------------------


def _solve_kirchhoff(n_nodes, node_a, node_b, conductance_s, source, sink, current_a):
    """Node potentials of independent networks stored as disjoint blocks of one graph.

    Block ``m`` receives ``current_a`` at node ``source[m]`` and is grounded at ``sink[m]``. Only
    the connected components holding a sink joined to its source are solved; every other node gets
    NaN. Returns ``(potential_v (n_nodes,), resistance_ohm (n_blocks,))`` with inf where the source
    and the sink are not connected.
    """
    from scipy import sparse  # here: only ball/ball contacts need it
    from scipy.sparse import csgraph
    from scipy.sparse.linalg import spsolve

    keep = conductance_s > 0.0
    a, b, c = node_a[keep], node_b[keep], conductance_s[keep]
    graph = sparse.coo_array((c, (a, b)), shape=(n_nodes, n_nodes))
    n_components, label = csgraph.connected_components(graph, directed=False)
    conducting = label[source] == label[sink]

    solved = np.zeros(n_components, dtype=bool)
    solved[label[sink[conducting]]] = True
    unknown_mask = solved[label]
    unknown_mask[sink] = False
    unknown = np.flatnonzero(unknown_mask)

    potential = np.full(n_nodes, np.nan)
    potential[sink[conducting]] = 0.0
    if unknown.size:
        # Weighted Laplacian on the unknown nodes; an edge to a grounded sink adds to the
        # diagonal only, an edge outside the solved components has no unknown end and drops out.
        index = np.full(n_nodes, -1)
        index[unknown] = np.arange(unknown.size)
        ia, ib = index[a], index[b]
        both = (ia >= 0) & (ib >= 0)
        rows = np.concatenate([ia[ia >= 0], ib[ib >= 0], ia[both], ib[both]])
        cols = np.concatenate([ia[ia >= 0], ib[ib >= 0], ib[both], ia[both]])
        vals = np.concatenate([c[ia >= 0], c[ib >= 0], -c[both], -c[both]])
        laplacian = sparse.csc_matrix((vals, (rows, cols)), shape=(unknown.size, unknown.size))
        rhs = np.zeros(unknown.size)
        rhs[index[source[conducting]]] = current_a
        potential[unknown] = np.atleast_1d(spsolve(laplacian, rhs))

    resistance = np.full(source.size, np.inf)
    resistance[conducting] = potential[source[conducting]] / current_a
    return potential, resistance


@dataclass(frozen=True)
class NetworkSolution:
    """Solution of one contact network (:func:`network_resistance`).

    ``resistance_ohm`` is +inf when no path joins the rings; then every potential is NaN and every
    current 0. Potentials of nodes outside the component joining the rings are NaN.
    """

    resistance_ohm: float
    node_potential_v: np.ndarray  # (n_nodes,)
    contact_current_a: np.ndarray  # (n_contacts,) into the ball through the contact
    ball_current_a: np.ndarray  # (n_balls,) current through the ball, >= 0
    ball_potential_v: np.ndarray  # (n_balls,) mean potential of the ball's contact nodes


def network_resistance(
    contact_ball,
    contact_node,
    contact_area_m2,
    contact_direction=None,
    *,
    conductivity_s_m: float,
    ball_volume_m3: float,
    injected_current_a: float = 0.1,
) -> NetworkSolution:
    """Resistance and currents of one instant's network from a general list of contacts.

    Each row is one contact seen from one ball: a ball/ring contact appears once, a ball/ball
    contact twice (once from each ball, same node). Every ball joins each pair of its contacts by
    the conductance of seed eq. 16; the current is injected at node ``OUTER_RING_NODE`` (0) and
    leaves at ``INNER_RING_NODE`` (1), held at 0 V.

    Parameters
    ----------
    contact_ball : array_like of int, shape (n_contacts,)
        Ball carrying the contact surface.
    contact_node : array_like of int, shape (n_contacts,)
        Network node of the contact point: 0 outer ring, 1 inner ring, >= 2 a contact point
        between balls (or any other conductor-free junction).
    contact_area_m2 : array_like, shape (n_contacts,)
        Contact area S (m^2); 0 for a contact that does not conduct.
    contact_direction : array_like, shape (n_contacts, n_dims), optional
        Vector from the ball centre towards the contact point (any length); theta of eq. 16 is the
        angle between two of them. ``None``: theta = pi for every pair (seed).
    conductivity_s_m, ball_volume_m3 : float
        gamma and V_b of eq. 16.
    injected_current_a : float
        Current I injected into the outer ring (A).

    Returns
    -------
    NetworkSolution
    """
    ball = np.asarray(contact_ball, dtype=np.intp).reshape(-1)
    node = np.asarray(contact_node, dtype=np.intp).reshape(-1)
    area = np.asarray(contact_area_m2, dtype=float).reshape(-1)
    if not ball.size == node.size == area.size:
        raise ValueError(
            f"contact_ball, contact_node, contact_area_m2 have {ball.size}, {node.size}, "
            f"{area.size} rows: must be equal"
        )
    if ball.size and (ball.min() < 0 or node.min() < 0):
        raise ValueError("contact_ball and contact_node must be >= 0")
    if not np.all(np.isfinite(area)):
        raise ValueError("contact_area_m2 must be finite")
    _check_current(injected_current_a)
    if contact_direction is None:
        unit = None
    else:
        direction = np.asarray(contact_direction, dtype=float)
        if direction.ndim != 2 or direction.shape[0] != ball.size:
            raise ValueError(
                f"contact_direction has shape {direction.shape}: must be ({ball.size}, n_dims)"
            )
        norm = np.linalg.norm(direction, axis=1)
        if np.any(~np.isfinite(norm) | (norm == 0.0)):
            raise ValueError("contact_direction rows must be finite and non-zero")
        unit = direction / norm[:, None]
    n_balls = int(ball.max()) + 1 if ball.size else 0
    n_nodes = max(int(node.max()) + 1 if node.size else 0, 2)

    # Every pair (p, q) of contacts on the same ball is one resistor of eq. 16.
    order = np.argsort(ball, kind="stable")
    starts = np.searchsorted(ball[order], np.arange(n_balls + 1))
    pairs = [
        order[starts[k] + np.stack(np.triu_indices(starts[k + 1] - starts[k], 1))]
        for k in range(n_balls)
    ]
    p, q = np.concatenate(pairs, axis=1) if pairs else np.zeros((2, 0), dtype=np.intp)
    cos_theta = -1.0 if unit is None else np.einsum("ij,ij->i", unit[p], unit[q])
    conductance = ball_conductance(
        np.maximum(area[p], 0.0),
        np.maximum(area[q], 0.0),
        cos_theta,
        conductivity_s_m=conductivity_s_m,
        ball_volume_m3=ball_volume_m3,
    )
    potential, resistance = _solve_kirchhoff(
        n_nodes,
        node[p],
        node[q],
        conductance,
        np.array([OUTER_RING_NODE]),
        np.array([INNER_RING_NODE]),
        injected_current_a,
    )
    flow = _edge_flow(conductance, potential[node[p]], potential[node[q]])
    contact_current = np.bincount(p, flow, minlength=ball.size) - np.bincount(
        q, flow, minlength=ball.size
    )
    ball_current = np.bincount(ball, np.maximum(contact_current, 0.0), minlength=n_balls)
    touching = area > 0.0
    count = np.bincount(ball, touching, minlength=n_balls)
    total = np.bincount(ball[touching], potential[node[touching]], minlength=n_balls)
    ball_potential = np.divide(total, count, out=np.full(n_balls, np.nan), where=count > 0)
    return NetworkSolution(
        float(resistance[0]), potential, contact_current, ball_current, ball_potential
    )


def _edge_flow(conductance_s, potential_a_v, potential_b_v):
    """Current a -> b through each resistor; 0 where the resistor lies outside the solved part."""
    with np.errstate(invalid="ignore"):
        flow = conductance_s * (potential_a_v - potential_b_v)
    return np.where(np.isfinite(flow), flow, 0.0)


def _check_current(injected_current_a) -> None:
    value = injected_current_a
    if not (isinstance(value, int | float | np.number) and math.isfinite(value) and value > 0):
        raise ValueError(f"injected_current_a = {value!r}: must be a finite number > 0")


# --- the bearing at every recorded instant -------------------------------------------------------


@dataclass(frozen=True)
class ElectricalResult:
    """Electrical state of a bearing at each recorded instant (:func:`bearing_electrics`).

    ``current_a`` is the current through each ball (the total entering it, equal to the total
    leaving it); with the cage on it flows from the outer to the inner ring and the balls' currents
    sum to the injected current. ``potential_v`` is the mean of the potentials of a ball's contact
    nodes (V_outer / 2 for a ball touching both rings), NaN for a ball touching nothing or when the
    resistance is inf.
    """

    resistance_ohm: np.ndarray  # (T,), +inf when no ball joins the rings
    current_a: np.ndarray  # (T, Z), >= 0
    potential_v: np.ndarray  # (T, Z)
    inner_area_m2: np.ndarray  # (T, Z)
    outer_area_m2: np.ndarray  # (T, Z)
    max_current_density_a_m2: np.ndarray  # (T,) largest |current| / area over all contacts


def bearing_electrics(
    inner_force_n,
    outer_force_n,
    bearing: Bearing,
    injected_current_a: float = 0.1,
    *,
    ball_xy_m=None,
    inner_ring_xy_m=None,
    ball_ball_force_n=None,
    density_limit_a_m2: float = DENSITY_LIMIT_A_M2,
    checked_instants=None,
) -> ElectricalResult:
    """Bearing resistance, ball currents and potentials from the contact forces (seed section 3).

    Contact areas follow eq. 18, each ball conducts by eq. 16 between each pair of its contacts,
    and the network is solved by Kirchhoff's law with ``injected_current_a`` into the outer ring and
    the inner ring at 0 V. Instants without ball/ball contact (always, with the cage on) are a
    parallel sum R = 1 / sum_k C_k, vectorised; the others go through the sparse solver.

    Parameters
    ----------
    inner_force_n, outer_force_n : array_like, shape (n_instants, n_balls)
        Normal forces of each ball on the inner / outer raceway (N); <= 0 is no contact. A 1-D
        array is one instant.
    bearing : Bearing
        Geometry (eqs 12-13), E_eq, gamma and V_b.
    injected_current_a : float
        Current I injected into the outer ring (A).
    ball_xy_m : array_like, shape (n_instants, n_balls, 2), optional
        Ball centres (m), outer-ring centre at the origin. When given, theta of eq. 16 is the angle
        between contact directions: the inner contact lies towards the inner-ring centre, the outer
        contact away from the origin, a ball/ball contact towards the neighbour. Otherwise
        theta = pi for the inner/outer pair, and ball/ball contacts take the nominal geometry of
        balls equally spaced on the pitch circle of concentric rings.
    inner_ring_xy_m : array_like, shape (n_instants, 2), optional
        Inner-ring centre (m); the origin when omitted. Needs ``ball_xy_m``.
    ball_ball_force_n : array_like, shape (n_instants, n_balls), optional
        Force between ball k and ball (k + 1) % Z (N), cage off only; ``None``: no such contact.
    density_limit_a_m2 : float
        Current density above which one :class:`CurrentDensityWarning` is emitted (A/m^2); the
        seed's 0.1 A/mm^2 by default, ``inf`` to silence.
    checked_instants : array_like of bool, shape (n_instants,), optional
        The instants the density check looks at (a run checks its steady phase: the set-up's
        first contacts are tiny and carry the whole current); all when omitted.

    Returns
    -------
    ElectricalResult
    """
    inner_force = _forces(inner_force_n, "inner_force_n")
    outer_force = _forces(outer_force_n, "outer_force_n")
    if inner_force.shape != outer_force.shape:
        raise ValueError(
            f"inner_force_n {inner_force.shape} and outer_force_n {outer_force.shape} must have "
            "the same shape (n_instants, n_balls)"
        )
    _check_current(injected_current_a)
    if not density_limit_a_m2 > 0.0:
        raise ValueError(f"density_limit_a_m2 = {density_limit_a_m2!r}: must be > 0")
    n_instants, n_balls = inner_force.shape

    inner_area = bearing_contact_area(inner_force, bearing, "inner")
    outer_area = bearing_contact_area(outer_force, bearing, "outer")
    geometry = _Geometry(ball_xy_m, inner_ring_xy_m, inner_force.shape, bearing)

    resistance = np.full(n_instants, np.inf)
    current = np.zeros((n_instants, n_balls))
    potential = np.full((n_instants, n_balls), np.nan)
    density = np.zeros(n_instants)

    if ball_ball_force_n is None:
        general = np.zeros(n_instants, dtype=bool)
    else:
        ball_ball_force = _forces(ball_ball_force_n, "ball_ball_force_n")
        if ball_ball_force.shape != inner_force.shape:
            raise ValueError(
                f"ball_ball_force_n {ball_ball_force.shape} must have the shape of inner_force_n "
                f"{inner_force.shape}"
            )
        if n_balls < 3:
            raise ValueError("ball/ball contacts need at least 3 balls")
        general = np.any(ball_ball_force > 0.0, axis=1)

    fast = ~general
    out = _parallel_balls(
        inner_area[fast],
        outer_area[fast],
        geometry.inner_outer_cos(fast),
        bearing,
        injected_current_a,
    )
    resistance[fast], current[fast], potential[fast], density[fast] = out
    if np.any(general):
        out = _ball_network(
            inner_area[general],
            outer_area[general],
            bearing_contact_area(ball_ball_force[general], bearing, "ball_ball"),
            geometry.directions(general),
            bearing,
            injected_current_a,
        )
        resistance[general], current[general], potential[general], density[general] = out

    checked = np.ones(n_instants, bool) if checked_instants is None else checked_instants
    checked = np.asarray(checked, dtype=bool)
    if checked.shape != (n_instants,):
        raise ValueError(f"checked_instants {checked.shape} must have shape ({n_instants},)")
    over = (density > density_limit_a_m2) & checked
    if np.any(over):
        warn_current_density(
            int(over.sum()),
            int(checked.sum()),
            float(density[checked].max()),
            density_limit_a_m2,
            injected_current_a,
            checked_instants is not None,
        )
    return ElectricalResult(resistance, current, potential, inner_area, outer_area, density)


def warn_current_density(
    n_over: int,
    n_checked: int,
    largest_a_m2: float,
    density_limit_a_m2: float,
    injected_current_a: float,
    checked: bool = True,
) -> None:
    """One :class:`CurrentDensityWarning`: ``n_over`` of ``n_checked`` instants above the limit
    (a run computed block by block counts over all its blocks, then warns once)."""
    warnings.warn(
        f"contact current density above {density_limit_a_m2 * 1e-6:g} A/mm^2 at "
        f"{n_over} of {n_checked} instants{' checked' if checked else ''} (largest "
        f"{largest_a_m2 * 1e-6:.3g} "
        f"A/mm^2, injected current {injected_current_a:g} A); seed section 3: above "
        "0.1 A/mm^2 the raceways are harmed",
        CurrentDensityWarning,
        stacklevel=3,
    )


def _forces(force_n, name: str) -> np.ndarray:
    force = np.atleast_2d(np.asarray(force_n, dtype=float))
    if force.ndim != 2:
        raise ValueError(f"{name} has shape {force.shape}: must be (n_instants, n_balls)")
    if not np.all(np.isfinite(force)):
        raise ValueError(f"{name} must be finite")
    return force


class _Geometry:
    """Unit vectors from each ball centre towards its contacts, actual or nominal."""

    def __init__(self, ball_xy_m, inner_ring_xy_m, shape, bearing: Bearing):
        n_instants, n_balls = shape
        self.given = ball_xy_m is not None
        if not self.given:
            if inner_ring_xy_m is not None:
                raise ValueError("inner_ring_xy_m needs ball_xy_m")
            psi = 2.0 * math.pi * np.arange(n_balls) / n_balls
            nominal = bearing.pitch_radius_m * np.stack([np.cos(psi), np.sin(psi)], axis=-1)
            ball_xy_m = np.broadcast_to(nominal, (n_instants, n_balls, 2))
            inner_ring_xy_m = np.zeros((n_instants, 2))
        self.ball_xy = np.asarray(ball_xy_m, dtype=float)
        if self.ball_xy.shape == (n_balls, 2) and n_instants == 1:
            self.ball_xy = self.ball_xy[None]
        if self.ball_xy.shape != (n_instants, n_balls, 2):
            raise ValueError(
                f"ball_xy_m has shape {self.ball_xy.shape}: must be ({n_instants}, {n_balls}, 2)"
            )
        ring = np.zeros(2) if inner_ring_xy_m is None else inner_ring_xy_m
        self.ring_xy = np.broadcast_to(np.asarray(ring, dtype=float), (n_instants, 2))
        if not (np.all(np.isfinite(self.ball_xy)) and np.all(np.isfinite(self.ring_xy))):
            raise ValueError("ball_xy_m and inner_ring_xy_m must be finite")

    @staticmethod
    def _unit(vector, what: str):
        norm = np.linalg.norm(vector, axis=-1, keepdims=True)
        if np.any(norm == 0.0):
            raise ValueError(f"{what}: zero distance, contact direction undefined")
        return vector / norm

    def _ring_units(self, rows):
        p = self.ball_xy[rows]
        outer = self._unit(p, "ball centre at the outer-ring centre")
        inner = self._unit(self.ring_xy[rows, None, :] - p, "ball centre at the inner-ring centre")
        return outer, inner

    def inner_outer_cos(self, rows):
        """cos theta between the inner and the outer contact of each ball, (n_rows, Z)."""
        if not self.given:
            return -1.0
        outer, inner = self._ring_units(rows)
        return np.sum(outer * inner, axis=-1)

    def directions(self, rows):
        """(outer, inner, previous ball, next ball) unit vectors, each (n_rows, Z, 2)."""
        outer, inner = self._ring_units(rows)
        p = self.ball_xy[rows]
        following = self._unit(np.roll(p, -1, axis=1) - p, "two ball centres coincide")
        return outer, inner, -np.roll(following, 1, axis=1), following


def _parallel_balls(inner_area, outer_area, cos_theta, bearing: Bearing, current_a):
    """Instants without ball/ball contact: every ball joins the two rings, in parallel."""
    conductance = ball_conductance(
        inner_area,
        outer_area,
        cos_theta,
        conductivity_s_m=bearing.electrical_conductivity_s_m,
        ball_volume_m3=bearing.ball_volume_m3,
    )
    total = conductance.sum(axis=1)
    on = total > 0.0
    resistance = np.divide(1.0, total, out=np.full(total.shape, np.inf), where=on)
    current = current_a * np.divide(
        conductance, total[:, None], out=np.zeros(conductance.shape), where=on[:, None]
    )
    touch_outer = outer_area > 0.0
    n_touch = touch_outer.astype(float) + (inner_area > 0.0)
    outer_potential = np.where(on, current_a * resistance, np.nan)
    potential = np.divide(
        touch_outer * outer_potential[:, None],
        n_touch,
        out=np.full(n_touch.shape, np.nan),
        where=(n_touch > 0) & on[:, None],
    )
    density = np.maximum(
        max_current_density_a_m2(current, inner_area), max_current_density_a_m2(current, outer_area)
    )
    return resistance, current, potential, density


def max_current_density_a_m2(current_a, area_m2):
    """Largest |current| / contact area over every axis but the first (0 where no area), A/m^2."""
    density = np.divide(
        np.abs(current_a), area_m2, out=np.zeros(np.shape(area_m2)), where=area_m2 > 0.0
    )
    return density.max(axis=tuple(range(1, density.ndim)), initial=0.0)


def _ball_network(inner_area, outer_area, ball_ball_area, directions, bearing, current_a):
    """Instants with ball/ball contacts: one block-diagonal Laplacian, solved at once.

    Per instant, local nodes are 0 outer ring, 1 inner ring and 2 + k the contact between balls k
    and k + 1 (isolated when that contact is open). Each ball has four contact slots (outer,
    inner, previous ball, next ball) and one resistor of eq. 16 per pair of slots.
    """
    n_rows, n_balls = inner_area.shape
    n_local = n_balls + 2
    k = np.arange(n_balls)
    previous = (k - 1) % n_balls
    slot_area = np.stack(
        [outer_area, inner_area, ball_ball_area[:, previous], ball_ball_area], axis=-1
    )
    local = np.stack(
        [np.full(n_balls, OUTER_RING_NODE), np.full(n_balls, INNER_RING_NODE), 2 + previous, 2 + k],
        axis=-1,
    )
    base = n_local * np.arange(n_rows)
    slot_node = base[:, None, None] + local[None]
    slot_unit = np.stack(directions, axis=2)  # (rows, Z, 4, 2)

    pa, pb = np.triu_indices(4, 1)
    cos_theta = np.sum(slot_unit[:, :, pa] * slot_unit[:, :, pb], axis=-1)
    conductance = ball_conductance(
        slot_area[..., pa],
        slot_area[..., pb],
        cos_theta,
        conductivity_s_m=bearing.electrical_conductivity_s_m,
        ball_volume_m3=bearing.ball_volume_m3,
    )
    potential, resistance = _solve_kirchhoff(
        n_rows * n_local,
        slot_node[..., pa].ravel(),
        slot_node[..., pb].ravel(),
        conductance.ravel(),
        base + OUTER_RING_NODE,
        base + INNER_RING_NODE,
        current_a,
    )
    slot_potential = potential[slot_node]
    flow = _edge_flow(conductance, slot_potential[..., pa], slot_potential[..., pb])
    slot_current = np.zeros(slot_area.shape)  # into the ball through each slot
    for pair, (i, j) in enumerate(zip(pa, pb, strict=True)):
        slot_current[..., i] += flow[..., pair]
        slot_current[..., j] -= flow[..., pair]
    current = np.maximum(slot_current, 0.0).sum(axis=-1)

    touching = slot_area > 0.0
    count = touching.sum(axis=-1)
    total = np.where(touching, slot_potential, 0.0).sum(axis=-1)
    ball_potential = np.divide(total, count, out=np.full(count.shape, np.nan), where=count > 0)
    density = max_current_density_a_m2(slot_current, slot_area)
    return resistance, current, ball_potential, density
