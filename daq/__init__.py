"""Data acquisition: drivers for the rig's protocols, schemes as plans, interlocks, the writer.
Never imports simulators/: it talks to the emulator exactly as to the rig."""
