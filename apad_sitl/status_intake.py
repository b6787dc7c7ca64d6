"""The fleet's AMUSSEL_STATUS frames into an aPad, in one batch (`mavlink_dialect.hot`).

Every aPad of a swarm in one process gets the same status datagrams: they are decoded once
(`hot_decode.SharedDecode`) and the fix table's checks of them made once, for all. Each aPad takes the
checked fixes into its own table, draws a latched aMussel's gain from its battery, and logs the raw frames.
"""

from __future__ import annotations

from apad_sitl.docking import CheckedStatuses, MusselFixTable, checked_statuses
from apad_sitl.energy import EnergyMeter
from apad_sitl.logs import VehicleLog
from mavlink_dialect import hot, hot_decode
from mavlink_dialect.codec import CodecStats

# One for every vehicle of the process: the aPads of a swarm get the same status datagrams.
_STATUS_DECODE = hot_decode.SharedDecode()
_last_checked: tuple[hot_decode.HotFrames, CheckedStatuses] | None = None


def _checked(split: hot_decode.Split) -> CheckedStatuses:
    """The fix table's checks of shared status frames, made once for all the aPads that got them."""
    global _last_checked
    last = _last_checked
    if last is None or last[0] is not split.hot:
        f = split.hot.fields
        last = _last_checked = split.hot, checked_statuses(f["mussel_id"], f["lat"], f["lon"], f["state"])
    return last[1]


def take_statuses(datagrams: list[bytes], stats: CodecStats, mussels: MusselFixTable, energy: EnergyMeter,
                  log: VehicleLog | None, now_us: int) -> list[bytes]:
    """Take the status frames among `datagrams` into `mussels` (and `energy`, and the .tlog at `now_us`);
    return every other frame, for the codec."""
    split = _STATUS_DECODE.decode(datagrams, hot.AMUSSEL_STATUS, stats, keep_raw=log is not None)
    if len(split.hot):
        mussels.take(_checked(split))
        if energy.listening:  # an aMussel latched here: its gain is drawn from the battery
            f = split.hot.fields
            energy.heard(zip(f["mussel_id"].tolist(), f["battery"].tolist(), split.hot.src_system.tolist(),
                             strict=True))
        if log is not None and split.hot.raw is not None:
            log.messages(now_us, split.hot.raw)
    return split.others
