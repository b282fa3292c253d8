"""`rig emulate`: the whole rig stand-in (PLC on Modbus TCP, drives behind socketcand) as its own
process on loopback. The stand-in and its options live in simulators.standin, which is also the
process entry point the service and the demo launch (`python -m simulators.standin`)."""

from simulators.standin import add_arguments, run

__all__ = ["add_arguments", "run"]
