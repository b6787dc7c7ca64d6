"""Share a fleet among several aPads: k-means on the aMussels' positions, then a balanced assignment.

k-means (scipy's `kmeans2`, k-means++ seeding) finds one centre per aPad; each centre goes to the
aPad nearest it (an optimal one-to-one matching), and each aMussel to a centre by a minimum-cost
assignment in which an aPad has `capacity` places, so no aPad gets more than it can serve however
the fleet is clustered (`scipy.optimize.linear_sum_assignment`). Pure: positions in, shares out.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Partition:
    """Which aPad serves which aMussels, and the centre (local metres) each share was built around."""

    shares: dict[int, list[int]]  # aPad system id -> aMussel ids, ascending
    centres: dict[int, tuple[float, float]]  # aPad system id -> (x, y) m

    def owner(self) -> dict[int, int]:
        """aMussel id -> the aPad that serves it."""
        return {m: apad for apad, ids in self.shares.items() for m in ids}


def partition(
    mussel_ids: NDArray[np.int64],
    xy_m: NDArray[np.float64],
    apads_xy_m: dict[int, tuple[float, float]],
    capacity: int | None = None,
    seed: int = 0,
) -> Partition:
    """Split `mussel_ids` (positions `xy_m`, shape (n, 2)) among the aPads at `apads_xy_m`.

    `capacity`: the most aMussels one aPad may get; default the even share, ceil(n / k). Raises
    ValueError if the aPads together cannot take them all, or if there is no aPad.
    """
    apads = sorted(apads_xy_m)
    k, n = len(apads), len(mussel_ids)
    if k == 0:
        raise ValueError("no aPad to share the fleet among")
    cap = math.ceil(n / k) if capacity is None else capacity
    if cap * k < n:
        raise ValueError(f"{k} aPads of {cap} places cannot serve {n} aMussels")
    # Imported here, not with the module: scipy's are ~0.4 s of every `vil` start, and a run of one
    # aPad never shares its fleet.
    from scipy.cluster.vq import kmeans2
    from scipy.optimize import linear_sum_assignment

    points = np.asarray(xy_m, np.float64).reshape(n, 2)
    homes = np.array([apads_xy_m[a] for a in apads], np.float64).reshape(k, 2)
    if n == 0:
        return Partition({a: [] for a in apads}, {a: apads_xy_m[a] for a in apads})
    if k == 1 or n <= k:
        centres = homes  # nothing to cluster: each aMussel to the nearest aPad with room
    else:
        with warnings.catch_warnings():  # an empty cluster is fine: the assignment below fills every aPad
            warnings.simplefilter("ignore")
            found, _ = kmeans2(points, k, minit="++", seed=np.random.default_rng(seed))
        # Each centre to the aPad nearest it, one to one.
        rows, cols = linear_sum_assignment(np.linalg.norm(homes[:, None, :] - found[None, :, :], axis=2))
        centres = found[cols[np.argsort(rows)]]
    # Each aPad offers `cap` places at its centre; each aMussel takes the cheapest (squared distance).
    cost = ((points[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)  # (n, k)
    taken, place = linear_sum_assignment(np.repeat(cost, cap, axis=1))
    share_of = place // cap
    shares = {a: sorted(int(mussel_ids[i]) for i in taken[share_of == j]) for j, a in enumerate(apads)}
    return Partition(shares, {a: (float(centres[j, 0]), float(centres[j, 1])) for j, a in enumerate(apads)})
