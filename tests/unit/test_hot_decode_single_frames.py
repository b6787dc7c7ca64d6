"""hot_decode on datagrams of one frame each (most of what an aPad receives: heartbeats, commands): the
split hands every frame that is not an unsigned AMUSSEL_STATUS on whole, and what the codec then makes of
the split is what it makes of the datagram itself."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from mavlink_dialect import Codec, hot, hot_decode, mavlink

KEY = bytes(range(32))


def message(kind: int, n: int) -> mavlink.MAVLink_message:
    if kind == 0:
        return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 4, 3)
    if kind == 1:
        return mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 33, n, 0, 0, 0, 0, 0)
    return mavlink.MAVLink_amussel_status_message(n, 1 + n % 100, 439_390_000, 154_390_000, 1.5, 0.5, 3700, 1, 1)


@given(kinds=st.lists(st.integers(0, 2), min_size=1, max_size=4), signed=st.booleans(), n=st.integers(0, 10**6))
def test_single_frame_datagrams_split_as_the_codec_reads_them(kinds: list[int], signed: bool, n: int) -> None:
    sender = Codec(7, 1)
    if signed:
        sender.enable_signing(KEY, link_id=0, ticks=lambda: 10**12)
    grams = [sender.encode(message(k, n)) for k in kinds]
    split = hot_decode.decode_datagrams(grams, hot.AMUSSEL_STATUS)
    hot_unsigned = [g for g, k in zip(grams, kinds, strict=True) if k == 2 and not signed]
    assert len(split.hot) == len(hot_unsigned) and split.bad == 0
    assert split.others == [g for g, k in zip(grams, kinds, strict=True) if not (k == 2 and not signed)]
    if hot_unsigned:
        assert split.hot.fields["mussel_id"].tolist() == [1 + n % 100] * len(hot_unsigned)
    reader = Codec(1, 1)
    if signed:
        reader.enable_signing(KEY, link_id=0, ticks=lambda: 10**12)
    want = [m.to_dict() for g in grams for m in reader.decode(g) if m.get_type() != "AMUSSEL_STATUS" or signed]
    again = Codec(1, 1)
    if signed:
        again.enable_signing(KEY, link_id=0, ticks=lambda: 10**12)
    assert [m.to_dict() for g in split.others for m in again.decode(g)
            if m.get_type() != "AMUSSEL_STATUS" or signed] == want
