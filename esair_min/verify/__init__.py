"""``esair new`` and ``esair verify``: a builder's own MIN robot started from a bundled one,
then proven on every target its MCUs allow (the Python core, the generated C on the host,
the PIC18F452 in gpsim, the ATmega328P in simavr) with the chip simulators' timing
budgets. docs/verify.md."""
