"""A strategy of your own, in a file of its own (docs/strategies.md walks through it).

The most urgent aMussel per metre: each free slot takes the candidate whose missing charge, divided
by the distance to it from the aPad's last stop, is largest. Run it, or sweep it against the others:

    vil run pool12 --strategy docs/examples/slack_first.py:slack_first
"""

import numpy as np

from vil.strategies import CostWeights, Plan, PlanInput, distance_m


def slack_first(inp: PlanInput, weights: CostWeights) -> Plan:
    plan: Plan = {}
    taken = np.zeros(len(inp.mussel_ids), bool)
    for apad, (lat, lon) in sorted(inp.apads.items()):
        route: list[int] = []
        for _ in range(min(inp.capacity[apad], int((~taken).sum()))):
            metres = distance_m(np.full(taken.size, lat), np.full(taken.size, lon), inp.lat_deg, inp.lon_deg)
            score = np.where(taken, -np.inf, (1.0 - inp.battery_frac) / (metres + 1.0))
            pick = int(np.argmax(score))
            taken[pick] = True
            route.append(int(inp.mussel_ids[pick]))
            lat, lon = float(inp.lat_deg[pick]), float(inp.lon_deg[pick])
        plan[apad] = route
    return plan
