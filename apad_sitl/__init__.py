"""SITL aPad: kinematic omnidirectional vehicle, docking slots, primitives, MAVLink vehicle endpoint."""
