"""Ground-control station: link, aPad API, planner, scenario loop, metrics, logs, TUI, CLI."""
