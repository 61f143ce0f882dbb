# The `acomm` command.
import argparse
import sys


def main(argv=None):
    p = argparse.ArgumentParser(prog="acomm", description="acomm: communication runtime for underwater and surface robot networks")
    from acomm import __version__

    p.add_argument("--version", action="version", version="acomm " + __version__)
    sub = p.add_subparsers(dest="cmd")

    b = sub.add_parser("bench", help="run a benchmark; prints JSON lines with --json")
    b.add_argument("name", help="core, queue, discovery, ..., compare, or all (all but compare)")
    b.add_argument("--json", action="store_true", help="one JSON object per line")
    b.add_argument("--only", help="footprint: one group of figures (frozen_cortex_m, romfs_cortex_m, mpy_cortex_m, "
                                  "frozen_i386, romfs_i386, mpy_i386, flash_text, unix64)")
    b.add_argument("--open", action="store_true", help="attack: the nodes' key in open mode, to see what it allows")

    br = sub.add_parser("bridge", help="a gateway to another protocol: 'bridge imc' speaks IMC over UDP (DUNE, Neptus)")
    from . import bridgecmd

    bridgecmd.add_arguments(br)

    d = sub.add_parser("demo", help="run the demonstration mission on the simulated ocean")
    from . import demo

    demo.add_arguments(d)

    e = sub.add_parser("emulate", help="an emulated modem on a pseudo-terminal (and TCP)")
    from . import emulate

    emulate.add_arguments(e)

    f = sub.add_parser("flash", help="copy a board's program (boards/NAME) to a MicroPython board with mpremote")
    from . import flash

    flash.add_arguments(f)

    z = sub.add_parser("fuzz", help="random and mutated inputs against every decoder, driver and the store")
    from . import fuzz

    fuzz.add_arguments(z)

    n = sub.add_parser("node", help="a node on modems (--modem KIND:DEVICE), UDP and/or TCP, with a console on stdin")
    from . import ipnode

    ipnode.add_arguments(n)

    rp = sub.add_parser("replay", help="feed a capture (acomm emulate --log) through a driver and print its events")
    from . import replay

    replay.add_arguments(rp)

    r = sub.add_parser("run", help="run a board's program (boards/NAME) on this computer, its UARTs on serial ports")
    from . import boardrun

    boardrun.add_arguments(r)

    sw = sub.add_parser("sweep", help="a parameter study: a grid of simulated runs over seeds, locally or on Dask")
    from . import sweep

    sweep.add_arguments(sw)

    args = p.parse_args(argv)
    if args.cmd == "bench":
        from . import bench

        return bench.main(args)
    if args.cmd == "bridge":
        return bridgecmd.main(args)
    if args.cmd == "demo":
        return demo.main(args)
    if args.cmd == "emulate":
        return emulate.main(args)
    if args.cmd == "flash":
        return flash.main(args)
    if args.cmd == "fuzz":
        return fuzz.main(args)
    if args.cmd == "node":
        return ipnode.main(args)
    if args.cmd == "replay":
        return replay.main(args)
    if args.cmd == "run":
        return boardrun.main(args)
    if args.cmd == "sweep":
        return sweep.main(args)
    p.print_help()
    return 2


if __name__ == "__main__":
    sys.exit(main())
