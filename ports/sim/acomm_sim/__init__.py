# The simulated ocean: a virtual clock, a shared acoustic medium and emulated
# modems that speak each real serial protocol, so acomm's real drivers run
# against them unmodified. Portable Python (no CPython-only modules) so that
# the driver <-> emulator tests also run on the MicroPython unix port.
