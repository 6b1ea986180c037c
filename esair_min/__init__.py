"""ESAIR MIN: board model, firmware generator and emulator for 8-bit robot boards."""

__version__ = "0.1.0"
