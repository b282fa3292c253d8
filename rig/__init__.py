"""Shared facts of the J4 test platform: joint parameters, physics terms, the effect vocabulary,
channel names, and the `rig` command line. Every other package may import this one; it imports
none of them (the CLI imports them lazily)."""

__version__ = "0.1.0"
