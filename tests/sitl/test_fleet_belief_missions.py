"""The loop's fleet-wide belief (`FleetKnowledge.believed`, `batteries`) against its scalar `battery`, bit for bit,
inside whole missions: at every look of every idle wait (the pool's read), over what the GCS really heard, on
both platforms. Between them the missions hold every kind of aMussel a belief treats apart: deployed, docked on
this aPad and on another, let go of since its last report, on a sleep order, under water heard acoustically
(an order's anchor too), depleted. The idle wait's wake time is held to the per-aMussel formulas it replaced."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable

import pytest
from wake_reference import same_instant, scalar_pool_look_by

from gcs.acoustic_net.knowledge import UNDERWATER
from gcs.loop import phases
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.wake_times import pool_look_by
from gcs.mission.headless import run_mission
from gcs.mission.platform import Platform
from gcs.scenario.reader import load_scenario
from mussel_sim.vocabulary import MusselState

EVERY_STATE = tuple(MusselState)


def kinds(knows: FleetKnowledge, m: int) -> list[str]:
    """What kind of belief the scalar takes for aMussel `m` now."""
    view = knows.api.mussels[m]
    found = [view.state.name.lower()]
    if view.state == MusselState.DOCKED:
        here = m in knows.docked().values()
        found.append("docked here" if here else "docked elsewhere")
        released_us = knows.api.link.registry.released_us.get(m)
        if not here and released_us is not None and released_us >= view.time_us:
            found.append("let go since its report")
    if m in knows.orders.duties:
        found.append("ordered")
    if knows.battery(m) == 0.0:
        found.append("believed empty")
    if knows.acoustic is not None and view.state in UNDERWATER:
        found.append("under water")
        if m in knows.orders.changed:
            found.append("anchored")
    return found


def sampled(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """Compared at every read of the pool, of a docked aMussel's charge and of the idle wait's wake time: the whole
    fleet's belief with the scalar's, and the wake time with the old one."""
    seen: Counter[str] = Counter()
    pool, charged = FleetKnowledge.pool, FleetKnowledge.charged

    def compare(knows: FleetKnowledge) -> None:
        ids = sorted(knows.api.mussels)
        scalar = [knows.battery(m).hex() for m in ids]
        assert [float(b).hex() for b in knows.believed(EVERY_STATE).battery] == scalar
        assert [float(b).hex() for b in knows.batteries(ids[::-1])] == scalar[::-1]
        for m in ids:
            seen.update(kinds(knows, m))
        seen["looks"] += 1

    def pool_read(knows: FleetKnowledge) -> list[int]:
        compare(knows)
        return pool(knows)

    def charged_read(knows: FleetKnowledge, mussel_id: int, strategy: str) -> bool:
        compare(knows)
        return charged(knows, mussel_id, strategy)

    def look_by(knows: FleetKnowledge) -> float | None:
        compare(knows)
        got = pool_look_by(knows)
        assert same_instant(got, scalar_pool_look_by(knows))
        seen["wake times"] += 1
        return got

    monkeypatch.setattr(FleetKnowledge, "pool", pool_read)
    monkeypatch.setattr(FleetKnowledge, "charged", charged_read)
    monkeypatch.setattr(phases, "pool_look_by", look_by)
    return seen


RUNS: list[tuple[str, str, float, Platform, Callable[[Counter[str]], bool]]] = [
    ("pool12x2", "keep_alive", 1500.0, Platform.EVENT,
     lambda s: s["docked here"] > 0 and s["docked elsewhere"] > 0 and s["let go since its report"] > 0),
    ("bay24-acoustic", "keep_alive", 1200.0, Platform.EVENT,
     lambda s: s["under water"] > 0 and s["ordered"] > 0 and s["anchored"] > 0 and s["docked here"] > 0),
    ("bay24-acoustic", "none", 1800.0, Platform.EVENT, lambda s: s["under water"] > 0 and s["believed empty"] > 0),
    ("pool12", "none", 2400.0, Platform.EVENT, lambda s: s["depleted"] > 0 and s["believed empty"] > 0),
    ("pool12x2", "cautious", 900.0, Platform.LOCKSTEP,
     lambda s: s["docked elsewhere"] > 0 and s["let go since its report"] > 0 and s["floating"] > 0),
]


@pytest.mark.parametrize(("name", "strategy", "duration_s", "platform", "holds"), RUNS,
                         ids=[f"{r[0]}-{r[1]}-{r[3]}" for r in RUNS])
def test_the_fleets_belief_is_the_scalar_one_at_every_look_of_a_mission(
        monkeypatch: pytest.MonkeyPatch, name: str, strategy: str, duration_s: float, platform: Platform,
        holds: Callable[[Counter[str]], bool]) -> None:
    seen = sampled(monkeypatch)
    run_mission(load_scenario(name).with_overrides(strategy=strategy, duration_s=duration_s), platform=platform)
    assert seen["looks"] > 20 and holds(seen), dict(seen)
