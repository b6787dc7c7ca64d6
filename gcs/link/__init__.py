"""The GCS's MAVLink link: a router that parses every datagram once, the vehicle registry it feeds,
and the command and parameter clients beside it."""
