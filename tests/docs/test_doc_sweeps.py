"""The docs' examples, run for real: the `vil sweep` and Dask examples.

How each runs and what of its claim is checked: tests/docs/doc_sweeps.py; which command is which run,
and its CI variant: tests/docs/doc_registry.py. The long tests run the commands as written."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from doc_harness import ROOT, Work
from doc_registry import runs_of
from doc_sweeps import check_shipped_spec

pytestmark = [pytest.mark.slow]

Check = Callable[[Callable[[Work], None], bool], None]


if runs_of("sweeps"):  # every sweep example runs under -m long for now (doc_registry.py says why)
    @pytest.mark.parametrize("run", runs_of("sweeps"), ids=lambda r: r.__name__.removeprefix("run_"))
    def test_the_example_runs_and_its_claim_holds(run: Callable[[Work], None], check: Check) -> None:
        check(run, False)


@pytest.mark.long
@pytest.mark.parametrize("run", runs_of("sweeps", full=True), ids=lambda r: r.__name__.removeprefix("run_"))
def test_the_example_as_written(run: Callable[[Work], None], check: Check) -> None:
    check(run, True)


def test_the_shipped_strategies_spec_is_the_360_missions_the_docs_name() -> None:
    """Every registered strategy x pool12, bay24 x seeds 1-20 (what the sweeps themselves run under -m long)."""
    assert check_shipped_spec(ROOT) == 360
