# MicroPython boards from this computer: a board's files and their
# compilation (boardfiles), copying them with mpremote (flash), a board's
# program run on CPython (boardrun), and the emulated boards the tests and
# benchmarks boot (qemuboard: Cortex-M3 in qemu; picoboard, picoflash: the
# RP2040 in rp2040js). Imports the library, the console, acomm_mp and
# acomm_web (a board's console).
