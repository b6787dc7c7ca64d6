"""What the GCS says to a submerged aMussel over the water.

A call-up is an acknowledged unicast (`$M`) of `CALL_UP` from the GCS's unit to the aMussel's
address: "surface, an aPad is near". It is retried up to `CALL_UP_TRIES` times while no
acknowledgement comes back. A sleeping aMussel is pinged first (`$P`): the ping wakes it, so the
call-up that follows is taken at once.
"""

from __future__ import annotations

CALL_UP = b"SU"  # the modem's shortest payload (2 bytes)
CALL_UP_TRIES = 3  # one call-up and two retries; past them the loop's surfacing wait decides
