"""Putting built firmware on a real chip: avrdude and Optiboot for ATmega328P boards
(``avr``), ESAIR's own serial bootloader for PIC18F452 boards (``pic``)."""


from esair_min.errors import EsairError


class FlashError(EsairError):
    """A flash that did not complete: the message names the likely cause and what to try."""
