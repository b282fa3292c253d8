"""Software stand-in for the J4 rig: joint physics (numba kernel), sensors, effects, and (later)
the PLC and drive stand-ins speaking the rig's protocols."""
