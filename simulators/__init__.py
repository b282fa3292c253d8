"""Software stand-in for the J4 rig: the joint's physics (numba kernel `kernel.py`, its set-up
`model.py`, `config.py`), sensors, whole-scheme simulation (`offline.py`), the live emulator
(`live.py`) behind the PLC stand-in on Modbus TCP (`plc.py`) and the CiA 402 drives behind a
socketcand server (`drives.py`, `socketcand_server.py`), assembled as one process in
`standin.py` (`rig emulate`). Imports only core/ (docs/architecture.md)."""
