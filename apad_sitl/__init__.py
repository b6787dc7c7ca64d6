"""SITL aPad: kinematic omnidirectional vehicle, docking slots, primitives, MAVLink vehicle endpoint.

Pure models (dt in, no clock, no I/O):
    params.py      ApadParams and the MAVLink parameter table (names, ranges, descriptions)
    vehicle.py     VehicleState, step(): bounded speed/acceleration, current, heading, battery
    primitives.py  Go To / Hold / Dock / Undock state machine over PrimitiveState and the four slots
Edges:
    messages.py    MAVLink messages built from model state (what an ArduRover boat sends)
    logs.py        the aPad's own .tlog and JSON-lines event log
    endpoint.py    SitlVehicle: the MAVLink vehicle, driven by a Scheduler
    serve.py       `vil sitl` / `python -m apad_sitl`: real time on UDP, TCP or serial

Import the module you need; this package imports nothing so the pure models stay light.
"""
