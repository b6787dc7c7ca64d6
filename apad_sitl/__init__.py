"""SITL aPad: kinematic omnidirectional vehicle, docking slots, primitives, MAVLink vehicle endpoint.

Pure models (dt in, no clock, no I/O):
    vocabulary.py  Primitive, Progress, Latch, RoverMode, N_SLOTS: the aPad's words, on the wire too
    params.py      ApadParams and the MAVLink parameter table (names, ranges, descriptions)
    vehicle.py     VehicleState, step(): bounded speed/acceleration, current, heading, battery
    primitives.py  Go To / Hold / Dock / Undock state machine over PrimitiveState and the four slots
Edges:
    messages.py    MAVLink messages built from model state (what an ArduRover boat sends)
    logs.py        the aPad's own .tlog and JSON-lines event log
    endpoint.py    SitlVehicle: the MAVLink vehicle's core (state, codec, poll loop, dispatch),
                   driven by a Scheduler, with one part per capability, each built with only
                   what it uses (host.py: the narrow PartHost and the words of commands;
                   state.py: ApadState, the shared state that reports its changes; dege7.py):
        commands.py          the command protocol and the MAV_CMD table
        streams.py           telemetry streams and requested messages
        modes.py             HOLD / GUIDED, arming, the GCS failsafe
        navigation.py        Go To (DO_REPOSITION, DO_CHANGE_SPEED)
        geofence.py          the water area Go To and Undock respect
        docking.py           the aMussel fix table, Dock and Undock
        param_server.py      the PARAM protocol
        mission_protocol.py  an empty mission list
    serve.py       `vil sitl` / `python -m apad_sitl`: real time on UDP, TCP or serial

Import the module you need; this package imports nothing so the pure models stay light.
"""
