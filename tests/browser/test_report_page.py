"""The report's page in a real Chromium: it loads with no console error, shows its tables and
every figure (decoded: naturalWidth > 0), and asks nothing of any machine but this one."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from gcs.cli.report import write_report
from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

if TYPE_CHECKING:
    from conftest import BrowserPage  # this folder's conftest: the page and what it recorded


@pytest.fixture(scope="module")
def report_page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("report")
    run_mission(load_scenario("pool12").with_overrides(duration_s=600.0), root / "run")
    write_report(root / "run", root / "report")
    return root / "report" / "index.html"


def test_report_page_shows_its_tables_and_figures_offline(page: BrowserPage, report_page: Path) -> None:
    tab = page.page
    tab.goto(report_page.as_uri(), wait_until="load")
    assert tab.locator("h1").inner_text() == "pool12 cautious seed 1"
    summary = tab.locator("table").first
    assert summary.is_visible() and "avg uptime %" in summary.inner_text()
    assert "paper (Table II)" in summary.inner_text()
    mussel_rows = tab.locator("#amussels + table tr")
    assert mussel_rows.count() == 1 + 12  # the header and a row per aMussel
    images = tab.evaluate("Array.from(document.images, i => [i.getAttribute('src'), i.complete, i.naturalWidth])")
    assert len(images) >= 6
    for src, complete, width in images:
        assert complete and width > 0, src
    assert tab.locator("#events ~ div.scroll table tr").count() > 10  # the event timeline
    assert page.console_errors == []
    assert page.outside_requests() == []
    assert sum(url.endswith(".png") for url in page.requests) == len(images)
