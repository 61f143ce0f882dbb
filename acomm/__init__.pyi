# Type stubs for acomm (PEP 561): the core runs unchanged on MicroPython, so
# its .py files carry no annotations; editors and mypy read these instead.
# tests/cpython/test_typing.py checks them against the modules.

__version__: str
