# The CPython port of acomm: byte streams (pyserial, sockets), asyncio glue,
# the `acomm` command line, benchmarks and demos. Never imported by the core.
