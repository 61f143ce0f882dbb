# acomm's MicroPython port: a board's node built from its configuration
# (boards/<name>/config.py), machine.UART byte streams, the flash store,
# the watchdog and the main loop. Everything here also imports on CPython,
# where the tests drive it with fake UARTs and a virtual clock.
