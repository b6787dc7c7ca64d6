"""The sea between the vehicles: the acoustic channel, TDMA, and the nanomodem v3 on a serial port.

Pure models (no I/O, no clock reads; time is passed in, randomness is a seeded numpy Generator):

- params.py        `AcousticParams`: the scenario's `[acoustic]` table (off by default)
- airtime.py       the nanomodem v3's packet durations (its user guide's formula), payload limits
- propagation.py   delay, Thorp absorption, spreading loss, noise and SNR (vectorised)
- per.py           packet error rate from SNR and payload size (noncoherent BFSK, FEC, fading)
- channel.py       `Medium`: transmissions in time, each reception decided once it has ended
                   (delay, half duplex, collisions, packet errors), deterministic from a seed
- tdma.py          the TDMA frame and slot table of a fleet over an area
- status_packet.py a submerged aMussel's status report in <= 64 bytes (struct)
- orders.py        what the GCS says to a submerged aMussel: the call-up and its retries

The serial modem (`acoustic.nanomodem`): the protocol (parser of commands, formatter and parser of
replies) and the emulator's core over a `Medium`, pure like the models above; and its edges, the
only I/O of this package: `ports.py` (a byte port: pyserial, or an in-process pipe for lockstep runs,
under the GCS's driver), `serve.py` (the emulator on a pty or serial device: `vil modem`, on the
wall clock) and `sea.py`'s `SeaClient` (simulated remote units' datagrams to `vil modem --sea`).

Imports: numpy, pyserial (ports.py only), and `missiontime` (the driver's bounded waits take a
Clock); never `gcs`.
"""
