# `acomm emulate <modem> --link PATH`: the front end of the emulator host
# (acomm_cpython.emulate.host): an emulated modem on a pseudo-terminal, its
# peers, TCP and --log; it runs until SIGTERM or Ctrl-C. SIGUSR1 fills the
# water with noise (every packet lost) and SIGUSR2 quiets it, for drills
# of a lost link (docs/mavlink.md).
import signal
import sys

from ..emulate.host import MODEMS, EmulatorHost, parse_peer
from acomm.errors import AcommError

from ..modems import hostport, parse_options


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
    g = p.add_argument_group("iridium: the gateway's shore services")
    g.add_argument("--directip", metavar="HOST:PORT", help="deliver each MO message by DirectIP to the server there")
    g.add_argument("--directip-mt", metavar="[HOST:]PORT", help="take MT messages by DirectIP here (0: any port)")
    g.add_argument("--rockblock-post", metavar="URL", help="POST each MO message there, as the RockBLOCK service does")
    g.add_argument("--rockblock-mt", metavar="[HOST:]PORT", help="serve the RockBLOCK MT API here (0: any port)")
    g.add_argument("--rockblock-credentials", metavar="FILE",
                   help="username= and password= the MT API takes (a file only its owner reads; default: any)")
    g.add_argument("--rockblock-public-key", metavar="PATH",
                   help="write the public half of the emulator's TEST signing key here, for the shore under test")
    g.add_argument("--shore-retry", type=float, default=60.0, metavar="S",
                   help="emulated seconds between deliveries to a shore server that is down (default 60)")


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
    shore = (args.directip, args.directip_mt, args.rockblock_post, args.rockblock_mt, args.rockblock_public_key)
    if any(x is not None for x in shore) and args.modem != "iridium":
        print("--directip and --rockblock-* are for iridium", file=sys.stderr)
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
    try:
        for line in _shore_services(args, host):
            print(line, flush=True)
    except (AcommError, OSError, ValueError) as e:
        host.close()
        print("cannot start the gateway's shore services: %s" % e, file=sys.stderr)
        return 1
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


def _shore_services(args, host):
    # the gateway's DirectIP and RockBLOCK services asked for -> lines to print
    lines = []
    retry_ms = int(args.shore_retry * 1000)
    if args.directip or args.directip_mt:
        from ..emulate.directipgw import DirectIpGateway

        mo_to = hostport(args.directip, "127.0.0.1") if args.directip else None
        mt = hostport(args.directip_mt, "127.0.0.1") if args.directip_mt else None
        gw = host.add_service(lambda net, now: DirectIpGateway(net, mo_to, mt, now, retry_ms))
        if mo_to:
            lines.append("gateway: MO by DirectIP to %s:%d" % mo_to)
        if mt:
            lines.append("gateway: MT DirectIP on %s:%d" % gw.mt_address)
    if args.rockblock_post or args.rockblock_mt or args.rockblock_public_key:
        from ..emulate.rockblockgw import RockblockGateway, public_test_pem
        from ..shore.rockblock import read_credentials

        if args.rockblock_public_key:
            with open(args.rockblock_public_key, "w") as f:
                f.write(public_test_pem())
            lines.append("gateway: the TEST key's public half in %s" % args.rockblock_public_key)
        creds = read_credentials(args.rockblock_credentials) if args.rockblock_credentials else None
        mt = hostport(args.rockblock_mt, "127.0.0.1") if args.rockblock_mt else None
        if args.rockblock_post or mt:
            gw = host.add_service(lambda net, now: RockblockGateway(net, args.rockblock_post, mt, creds, now, retry_ms))
            if args.rockblock_post:
                lines.append("gateway: MO by RockBLOCK POST to %s" % args.rockblock_post)
            if mt:
                lines.append("gateway: RockBLOCK MT API on http://%s:%d/rockblock/MT" % gw.mt_address)
    return lines
