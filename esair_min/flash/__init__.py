"""Putting built firmware on a real chip: avrdude and Optiboot for ATmega328P boards
(``avr``), ESAIR's own serial bootloader for PIC18F452 boards (``pic``)."""


class FlashError(Exception):
    """A flash that did not complete: the message names the likely cause and what to try."""
