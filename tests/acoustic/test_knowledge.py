"""The GCS's belief of an aMussel it hears now and then (`believed_battery`), as a pure function."""

from __future__ import annotations

import pytest

from gcs.acoustic_net.knowledge import believed_battery
from gcs.link.telemetry import MusselView
from mussel_sim.vocabulary import MusselState

DRAIN = 0.001  # battery fraction per mission second


def view(state: MusselState, battery: float = 0.6, time_us: int = 0) -> MusselView:
    return MusselView(7, 0, 0, 0.0, battery, 4000, state, True, time_us)


@pytest.mark.parametrize("state", [MusselState.ACTIVE, MusselState.SINKING, MusselState.SURFACING])
def test_under_water_the_report_runs_down_since_it_was_made(state: MusselState) -> None:
    assert believed_battery(view(state, time_us=2_000_000), 12_000_000, DRAIN) == pytest.approx(0.6 - 10 * DRAIN)
    assert believed_battery(view(state, battery=0.005), 12_000_000, DRAIN) == 0.0  # never below empty


@pytest.mark.parametrize("state", [MusselState.FLOATING, MusselState.DOCKED, MusselState.DEPLETED])
def test_at_the_surface_or_depleted_the_report_stands(state: MusselState) -> None:
    assert believed_battery(view(state), 60_000_000, DRAIN) == 0.6


def test_after_a_duty_change_the_run_down_starts_where_the_old_duty_left_it() -> None:
    # Reported at 0 s; a sleep order at 20 s, when 0.6 - 20 x DRAIN was believed; a tenth of the drain since.
    anchor = (20_000_000, 0.58)
    assert believed_battery(view(MusselState.ACTIVE), 30_000_000, DRAIN / 10, anchor=anchor) == pytest.approx(0.579)
    # A report newer than the change is the fresher knowledge: the run-down starts at the report.
    fresh = view(MusselState.ACTIVE, battery=0.5, time_us=25_000_000)
    assert believed_battery(fresh, 30_000_000, DRAIN / 10, anchor=anchor) == pytest.approx(0.4995)
