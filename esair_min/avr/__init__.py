"""The ATmega328P: avr-gcc builds of the generated firmware and the simavr harness."""
