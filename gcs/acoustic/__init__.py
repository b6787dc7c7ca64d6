"""The GCS's side of the acoustic room (acoustic/): what a scenario's fleet and area mean to the
channel and the TDMA frame (frames.py), and the figures and tables of docs/acoustic.md (figures.py).
The loop's use of the channel (planning on what was heard, acoustic call-ups) plugs in here next."""
