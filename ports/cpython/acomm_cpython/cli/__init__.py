# The `acomm` command (setup.cfg: acomm = acomm_cpython.cli:main). Each
# subcommand is one module of this package with add_arguments(parser) and
# main(args) -> exit status, listed in COMMANDS and imported only when it
# runs: `acomm --help` imports none, `acomm node ...` only the node's
# front end and what it needs (no simulator, no board tools).
#
# The front ends hold the argument parsing and the exit statuses; what they
# drive is in the groups beside this one (docs/architecture.md, "The CPython
# port"): the library (streams, udp, tcp, modems) at the top, console/,
# emulate/, bridges/, demo/, board/ and bench/.
import argparse
import importlib
import sys

# name -> (module of this package, one line of help), in the order --help lists them
COMMANDS = {
    "bench": ("bench", "run a benchmark; prints JSON lines with --json"),
    "bridge": ("bridge", "a gateway to another protocol: 'bridge imc' speaks IMC over UDP (DUNE, Neptus), "
                          "'bridge mavlink' MAVLink to an ArduSub vehicle and its ground station"),
    "demo": ("demo", "run the demonstration mission on the simulated ocean"),
    "emulate": ("emulate", "an emulated modem on a pseudo-terminal (and TCP)"),
    "flash": ("flash", "copy a board's program (boards/NAME) to a MicroPython board with mpremote"),
    "fuzz": ("fuzz", "random and mutated inputs against every decoder, driver and the store"),
    "node": ("node", "a node on modems (--modem KIND:DEVICE), UDP and/or TCP, with a console on stdin"),
    "replay": ("replay", "feed a capture (acomm emulate --log) through a driver and print its events"),
    "run": ("run", "run a board's program (boards/NAME) on this computer, its UARTs on serial ports"),
    "sweep": ("sweep", "a parameter study: a grid of simulated runs over seeds, locally or on Dask"),
}


def command(name):
    """The front-end module of subcommand `name` (imported now)."""
    return importlib.import_module("." + COMMANDS[name][0], __name__)


def _chosen(argv):
    # the subcommand named on the line: its first word that is not an option
    # (the top level's options, --version and --help, take no value)
    for a in argv:
        if not a.startswith("-"):
            return a if a in COMMANDS else None
    return None


def main(argv=None):
    from acomm import __version__

    if argv is None:
        argv = sys.argv[1:]
    p = argparse.ArgumentParser(prog="acomm", description="acomm: communication runtime for underwater and surface "
                                                           "robot networks")
    p.add_argument("--version", action="version", version="acomm " + __version__)
    sub = p.add_subparsers(dest="cmd")
    chosen = _chosen(argv)
    mod = None
    for name, (_, text) in COMMANDS.items():
        sp = sub.add_parser(name, help=text)
        if name == chosen:
            mod = command(name)
            mod.add_arguments(sp)
    args = p.parse_args(argv)
    if mod is None:
        p.print_help()
        return 2
    return mod.main(args)
