# acomm: a small communication runtime for underwater and surface robot networks.
# The core in this package runs unchanged on MicroPython >= 1.23 and CPython >= 3.9.
__version__ = "0.1.0"
