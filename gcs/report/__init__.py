"""`vil report`'s figures, page and GeoJSON of a recorded run, and several runs compared."""
