"""Regenerate the saved start configurations the shipped scenarios use (every strategy, same fleet).

    .venv/bin/python missions/make_start_configs.py

Positions uniform in the area, batteries uniform in [0.6, 1] (the paper, section V-A).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mussel_sim.placement import load_area
from mussel_sim.startconfig import generate_start_config, save_start_config

HERE = Path(__file__).resolve().parent
STARTS = {"pool12": ("pool", 12, 20200612), "bay24": ("bay", 24, 20200613)}


def main() -> None:
    for name, (area_name, count, seed) in STARTS.items():
        area = load_area(HERE / "areas" / f"{area_name}.geojson")
        config = generate_start_config(area, count, area.frame(), np.random.default_rng(seed))
        path = HERE / "starts" / f"{name}.geojson"
        save_start_config(path, config)
        print(f"{path}: {count} aMussels, batteries {config.battery_frac.min():.3f}..{config.battery_frac.max():.3f}")


if __name__ == "__main__":
    main()
