# `acomm emulate <modem> --link PATH`: the front end of the emulator host
# (acomm_cpython.emulate.host): an emulated modem on a pseudo-terminal, its
# peers, TCP and --log; it runs until SIGTERM or Ctrl-C. SIGUSR1 fills the
# water with noise (every packet lost) and SIGUSR2 quiets it, for drills
# of a lost link (docs/mavlink.md).
import signal
import sys

from ..emulate.host import MODEMS, EmulatorHost, parse_peer
from ..modems import parse_options


def add_arguments(p):
    p.add_argument("modem", choices=sorted(MODEMS), help="which modem to emulate")
    p.add_argument("--link", required=True, help="path of the symlink to the pseudo-terminal (the 'serial port')")
    p.add_argument("--address", type=int, default=1, help="the emulated modem's own address (default 1)")
    p.add_argument("--peer", action="append", default=[], metavar="ADDR[:PATH[:METRES]]",
                   help="another emulated modem in the water, on its own pty when PATH is given")
    p.add_argument("--distance", type=float, default=100.0, help="default distance between modems, m")
    p.add_argument("--loss", type=float, default=0.0, help="probability that a packet is lost")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--time-scale", type=float, default=1.0, help="emulated seconds per real second")
    p.add_argument("--tcp", type=int, default=None, nargs="?", const=-1, metavar="PORT",
                   help="also serve the modem over TCP (EvoLogics: port 9200 by default)")
    p.add_argument("--tcp-host", default="127.0.0.1")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="emulator option, e.g. packet_ms=100 (repeatable)")
    p.add_argument("--log", metavar="FILE", help="write every byte of the first modem's port, each way, with its "
                                                 "time (JSON lines; for acomm replay)")
    p.add_argument("--mt", action="append", default=[], metavar="HEX",
                   help="iridium, gsm: a message (hex bytes) waiting for the modem at the gateway (repeatable)")


def main(args):
    try:
        options = parse_options(args.option)
    except ValueError as e:
        print(e, file=sys.stderr)
        return 2
    try:
        incoming = [bytes.fromhex(h) for h in args.mt]
    except ValueError:
        print("--mt wants hex bytes", file=sys.stderr)
        return 2
    if incoming and args.modem not in ("iridium", "gsm"):
        print("--mt is for iridium and gsm", file=sys.stderr)
        return 2
    tcp = args.tcp
    if tcp == -1:
        tcp = MODEMS[args.modem][2] or 0
    log = None
    try:
        if args.log:
            from ..emulate.capture import CaptureWriter

            log = CaptureWriter(open(args.log, "w"), args.modem)
        host = EmulatorHost(args.modem, args.link, args.address, [parse_peer(p) for p in args.peer], options,
                            args.distance, args.loss, args.seed, args.time_scale, tcp, args.tcp_host, incoming,
                            log)
    except ImportError as e:
        print("the %s emulator is not available: %s" % (args.modem, e), file=sys.stderr)
        return 1
    except (OSError, TypeError, ValueError) as e:
        print("cannot start the %s emulator: %s" % (args.modem, e), file=sys.stderr)
        return 1
    stopping = []

    def stop(*_):
        stopping.append(1)

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)

    def noise(on):
        # SIGUSR1: noise in the water, every packet lost; SIGUSR2: quiet again
        host.medium.loss = 1.0 if on else args.loss
        print("water: %s" % ("noise, every packet lost" if on else "quiet, loss %g" % args.loss), flush=True)

    signal.signal(signal.SIGUSR1, lambda *_: noise(True))
    signal.signal(signal.SIGUSR2, lambda *_: noise(False))
    for st in host.stations:
        where = "%s -> %s" % (st.pty.link, st.pty.device) if st.pty and st.pty.link else "headless"
        if st.tcp:
            where += ", tcp %s:%d" % (args.tcp_host, st.tcp.port)
        print("%s emulator, address %d: %s" % (args.modem, st.address, where), flush=True)
    try:
        host.run(lambda: stopping)
    finally:
        host.close()
    return 0
