# The CPython port of acomm. Never imported by the core. Its groups, named
# after who uses them; each imports only the core and the groups of its row
# (tests/cpython/test_port_layers.py):
#
#   (top level)  the library: streams (serial, TCP), udp, tcp, modems (--modem,
#                the command lines' shared helpers), the asyncio node   core
#   console/     the console of acomm node and acomm run                library, acomm_web
#   emulate/     the emulators' ptys and TCP, captures, replay           library, acomm_sim
#   shore/       a shore link through the Iridium gateway, no modem     library
#   bridges/     gateways to other protocols (IMC)                       library, acomm_sim
#   demo/        the demo mission and sweeps on the simulated ocean      library, acomm_sim, acomm_web
#   board/       a board's files, flash, acomm run, emulated boards      library, console, acomm_mp, acomm_web
#   bench/       the benchmarks, their workloads, BENCHMARKS.md          library, board, demo, emulate, sim, web, mp
#   cli/         the acomm command, one module per subcommand            everything
