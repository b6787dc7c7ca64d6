"""The docs' examples, run for real: the consoles (`vil gcs`, `vil replay`) on a pseudo-terminal.

How each runs and what of its claim is checked: tests/docs/doc_consoles.py; which command is which run,
and its CI variant: tests/docs/doc_registry.py. The long tests run the commands as written."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from doc_harness import Work
from doc_registry import runs_of

pytestmark = [pytest.mark.tui, pytest.mark.slow]

Check = Callable[[Callable[[Work], None], bool], None]


@pytest.mark.parametrize("run", runs_of("consoles"), ids=lambda r: r.__name__.removeprefix("run_"))
def test_the_example_runs_and_its_claim_holds(run: Callable[[Work], None], check: Check) -> None:
    check(run, False)


@pytest.mark.long
@pytest.mark.parametrize("run", runs_of("consoles", full=True), ids=lambda r: r.__name__.removeprefix("run_"))
def test_the_example_as_written(run: Callable[[Work], None], check: Check) -> None:
    check(run, True)
