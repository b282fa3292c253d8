"""The shared core of facts of the J4 test platform: joint parameters (`params`), physics terms
(`terms`), the effect vocabulary (`effects`), channel names (`channels`), the schemes
(`schemes`, `excitation`), the PLC register map (`plc_map`), the drives' object dictionary
(`drive_od`, `drives.eds`), runs in memory and in files (`run`, `runfile`, `emps`) and the
acceptance indicators (`acceptance`). It imports no other package of this repository; every
other package may import it (docs/architecture.md)."""

__version__ = "0.1.0"
