"""aMussel fleet simulator: battery, positions and drift, sensors, states, comms. Pure models take dt."""
