"""Shared test setup: deterministic environment for every layer."""

from __future__ import annotations

import os

# NO_COLOR changes Textual's rendering and breaks snapshots (NOTES.md).
os.environ.pop("NO_COLOR", None)
