"""One aPad's energy-sharing loop (the paper's Fig. 7) and its parts: what it knows of the fleet, the aPad's
actions with their waits, the phases and the turns they make, the share of the fleet among several aPads."""
