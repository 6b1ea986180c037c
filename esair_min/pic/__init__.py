"""The PIC18F452 side: finding and running the toolchain (``toolchain``), building every
board (``build``), and the gpsim harnesses that run the generated firmware and compare
it with the Python core (``gpsim_*``).
"""
