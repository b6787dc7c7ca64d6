"""The nanomodem v3 on a serial port (its user guide v3.2; NOTES.md "Underwater acoustics").

- grammar.py   an incremental matcher of byte templates (literals, fixed-width numbers, counted data)
- commands.py  the commands the host writes (`$` + letter, no terminator) and their parser, which
               also answers a gap of more than ~2 ms between a command's bytes
- replies.py   what the modem writes back (acknowledgements `$...`, results `#...`, `E`; CR LF) and
               their parser, for the driver
- emulator.py  the emulator's pure core: a local modem and simulated remote units over a `Medium`
- serve.py     its edge: a pty (or a serial device) in real time; `vil modem`
- driver.py    the GCS's driver over a `BytePort`: pyserial (a real unit, a pty) or an in-process pipe
"""
