"""Data acquisition: the drivers of the rig's protocols (Modbus TCP to the PLC, CiA 402 drives over
CANopen), the DAQ facade (`rig.py`), schemes as plans (`plans.py`), interlocks, the engine that
runs a plan into the database (`engine.py`) with its run record's documents (`run_record.py`) and
sample alignment (`sample_alignment.py`), and the DAQ settings (`settings.py`). Never imports
simulators/: it talks to the emulator exactly as to the rig (docs/architecture.md)."""
