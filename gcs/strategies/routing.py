"""Prize-collecting routes, solved exactly with OR-Tools CP-SAT: which candidates, in which order.

One aPad leaves its position, visits at most `capacity` candidates and may end anywhere. Each
candidate left out costs its `prize` (metres the aPad would travel to take it); the solver
minimises metres travelled plus prizes forgone, and proves it. The model is one circuit
constraint (`add_circuit`) over the aPad, the candidates and an open end reached at no cost:
a candidate's self-loop taken means it is skipped. The routing library's local search finds a
route 10 m longer than the best in some draws of 10 aMussels; CP-SAT on these <= 26 nodes is
exact in tens of milliseconds.

A pool far larger than that (stress240: 100 and more candidates) makes a model of tens of thousands of
arcs that CP-SAT cannot prove within its work limit: every plan then took the whole limit (4 s here, 7
minutes of planning in a 40-minute mission) and gave its best so far, no optimum either. So at most
`MAX_CANDIDATES` (40, proved in about 0.2 s) are offered: those that could gain the most, a prize less the
shortest leg that could reach it (from the aPad or another candidate). Every other shipped scenario's pools
stay well under it (23 at most in bay120's), so their plans are the exact ones.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from mussel_sim.geo import distance_m

SCALE = 100  # the solver works in integers: centimetres
# A safety bound only (the search proves the optimum long before), then its best so far. In CP-SAT's
# deterministic time, not wall time: a loaded machine must not change a plan (sweeps repeat rows exactly).
WORK_LIMIT = 5.0
MAX_CANDIDATES = 40  # proved in a fifth of a second here; a larger pool is cut to its likeliest gains


def metres_matrix(lat_deg: NDArray[np.float64], lon_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """Geodesic metres between every pair of points. Shape (n, n); read-only. Remembered for the last
    point sets: a waiting aPad's strategy asks again for the same fixes every few seconds, and the
    geodesic's n^2 pairs are most of what a plan costs then."""
    return _metres_of(np.ascontiguousarray(lat_deg, np.float64).tobytes(),
                      np.ascontiguousarray(lon_deg, np.float64).tobytes())


@functools.lru_cache(maxsize=64)  # each aPad's share and routes; thread-safe (a sweep's worker threads)
def _metres_of(lat_bytes: bytes, lon_bytes: bytes) -> NDArray[np.float64]:
    lat, lon = np.frombuffer(lat_bytes, np.float64), np.frombuffer(lon_bytes, np.float64)
    i, j = np.meshgrid(np.arange(len(lat)), np.arange(len(lat)), indexing="ij")
    metres = distance_m(lat[i].ravel(), lon[i].ravel(), lat[j].ravel(), lon[j].ravel()).reshape(i.shape)
    metres.flags.writeable = False
    return metres


def best_route(start: tuple[float, float], lat_deg: NDArray[np.float64], lon_deg: NDArray[np.float64],
               prize_m: NDArray[np.float64], capacity: int) -> list[int]:
    """Indices of the candidates to visit, in order, from `start`. Candidates with no prize are never
    worth a detour and are left out before the solver sees them."""
    from ortools.sat.python import cp_model  # here: importing OR-Tools takes a second every `vil` would pay

    keep = np.flatnonzero(prize_m > 0)
    if capacity <= 0 or keep.size == 0:
        return []
    if keep.size > MAX_CANDIDATES:
        keep = likeliest(start, lat_deg, lon_deg, prize_m, keep)
    n = len(keep)
    metres = np.rint(metres_matrix(np.concatenate(([start[0]], lat_deg[keep])),
                                   np.concatenate(([start[1]], lon_deg[keep]))) * SCALE).astype(int)
    prize = np.rint(prize_m[keep] * SCALE).astype(int)
    end = n + 1  # nodes: 0 the aPad, 1..n the candidates, n + 1 the open end
    model = cp_model.CpModel()
    arcs: list[tuple[int, int, cp_model.LiteralT]] = []
    objective: list[cp_model.LinearExprT] = []
    visit = [model.new_bool_var(f"visit{k}") for k in range(1, n + 1)]
    for k in range(1, n + 1):
        arcs.append((k, k, ~visit[k - 1]))  # the self-loop: skipped
        objective.append(int(prize[k - 1]) * (1 - visit[k - 1]))
        arcs.append((k, end, model.new_bool_var("")))
    for a in range(n + 1):
        for b in range(1, n + 1):
            if a != b:
                x = model.new_bool_var(f"{a}>{b}")
                arcs.append((a, b, x))
                objective.append(int(metres[a, b]) * x)
    arcs.append((0, end, model.new_bool_var("")))  # visit nobody
    arcs.append((end, 0, model.new_constant(1)))
    model.add_circuit(arcs)
    model.add(sum(visit) <= capacity)
    model.minimize(sum(objective))
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1  # deterministic
    solver.parameters.max_deterministic_time = WORK_LIMIT
    if solver.solve(model) not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return []
    succ = {a: b for a, b, lit in arcs if a != b and solver.boolean_value(lit)}
    route, node = [], succ[0]
    while node != end:
        route.append(int(keep[node - 1]))
        node = succ[node]
    return route


def likeliest(start: tuple[float, float], lat_deg: NDArray[np.float64], lon_deg: NDArray[np.float64],
               prize_m: NDArray[np.float64], keep: NDArray[np.intp]) -> NDArray[np.intp]:
    """The `MAX_CANDIDATES` of `keep` that could gain the most: each one's prize less the shortest leg into it
    (from the aPad or another candidate), the most first (ties: the lower index), in index order."""
    metres = metres_matrix(np.concatenate(([start[0]], lat_deg[keep])), np.concatenate(([start[1]], lon_deg[keep])))
    into = metres[:, 1:] + np.vstack([np.zeros(len(keep)), np.diag(np.full(len(keep), np.inf))])  # no self-loop
    gain = prize_m[keep] - into.min(axis=0)
    best = np.argsort(-gain, kind="stable")[:MAX_CANDIDATES]
    return keep[np.sort(best)]
