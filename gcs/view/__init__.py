"""What a mission looks like, read from the link's registry and the mission's events, for the live
console and for the records (replay, report) alike: model (`MissionView`: the registry now, its
history, the events), snapshot (the frozen `Snapshot` it hands out), columns (its history rows and
fleet columns). Imports the link, never the console or the records."""
