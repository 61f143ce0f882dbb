# `acomm bridge mavlink`: cli/bridgemav.py.
# `acomm bridge imc`: the IMC gateway on the command line (docs/imc.md,
# "Gateway"). Either a simulated network (--sim: every simulated node is an
# IMC system with its own UDP port, run in real time or --speed times
# faster), or one node on real modems (--modem KIND:DEVICE[:BAUD] or
# KIND:tcp:HOST:PORT, repeated for more links).
#
# The first line printed is JSON: each system's name, IMC id and UDP port,
# and the discovery port, so a script can find a gateway bound to port 0.
# At the end (--seconds, or Ctrl-C) one JSON line of counters.

import json
import signal
import sys

from acomm.compat import ticks_ms
from acomm.errors import AcommError

from ..bridges.imcbridge import ANNOUNCE_GROUP, DATA_PORT, ImcBridge
from ..bridges.imcnodes import build_real, build_sim, gateways
from ..modems import ModemError, interrupt


def add_arguments(parser):
    sub = parser.add_subparsers(dest="protocol", required=True, metavar="PROTOCOL")
    p = sub.add_parser("imc", help="IMC over UDP: LSTS DUNE and Neptus (docs/imc.md)")
    _imc_arguments(p)
    from .bridgemav import add_arguments as mavlink_arguments

    mavlink_arguments(sub.add_parser("mavlink", help="MAVLink at both ends of an acoustic link: a GCS's joystick "
                                                     "drives an ArduSub vehicle (docs/mavlink.md)"))


def _imc_arguments(p):
    p.add_argument("--port", type=int, default=DATA_PORT,
                   help="UDP port of the (first) system, trying 5 from there as DUNE does; 0: any (default %(default)s)")
    p.add_argument("--host", default="0.0.0.0", help="address the UDP sockets bind to")
    p.add_argument("--imc-id", type=lambda s: int(s, 0), default=0x4000,
                   help="IMC id base: a system's id is this plus its acomm node id (default 0x4000)")
    p.add_argument("--map", action="append", default=[], metavar="IMCNAME=ACOMMNAME",
                   help="an IMC system name for an acomm node of another name")
    p.add_argument("--peer", action="append", default=[], metavar="HOST:PORT",
                   help="a static destination of everything published (UamRxFrame, UamRxRange)")
    p.add_argument("--lifespan", type=float, default=60.0, metavar="S", help="lifespan of a UamTxFrame (s)")
    p.add_argument("--announce-period", type=float, default=10.0, metavar="S", help="seconds between Announces")
    p.add_argument("--iface", default="0.0.0.0", metavar="ADDR", help="interface address for multicast")
    p.add_argument("--no-multicast", action="store_true", help="do not announce to, or listen on, 224.0.75.69")
    p.add_argument("--broadcast", default="255.255.255.255", metavar="ADDR",
                   help="broadcast address of the Announces ('none': no broadcast)")
    p.add_argument("--seconds", type=float, help="stop after this long")
    g = p.add_argument_group("simulated network")
    g.add_argument("--sim", action="store_true", help="bridge a simulated network instead of real modems")
    g.add_argument("--sim-node", action="append", default=[], metavar="NAME=ID",
                   help="a simulated node (default: topside=1 auv=2); each is an IMC system on the next port")
    g.add_argument("--sim-modem", default="seatrac", help="the simulated modems (default %(default)s)")
    g.add_argument("--distance", type=float, default=120.0, metavar="M", help="metres between simulated nodes")
    g.add_argument("--speed", type=float, default=1.0, help="simulated seconds per real second")
    g.add_argument("--seed", type=int, default=1, help="the simulation's seed")
    r = p.add_argument_group("real modems")
    r.add_argument("--name", help="this node's acomm name (and IMC system name)")
    r.add_argument("--id", type=int, help="this node's acomm id, 0..254 or 256..65534")
    r.add_argument("--known", action="append", default=[], metavar="NAME=ID", help="another acomm node")
    r.add_argument("--modem", action="append", default=[], metavar="KIND:DEVICE[:BAUD]|KIND:tcp://HOST:PORT",
                   help="a modem link (seatrac, evologics, micromodem, benthos, iridium, sms, transparent), "
                        "as for acomm node")


def main(args):
    if args.protocol == "mavlink":
        from .bridgemav import main as mavlink_main

        return mavlink_main(args)
    try:
        nodes, advance, world = build_sim(args) if args.sim else build_real(args)
    except ModemError as e:
        print("acomm bridge imc: %s" % e, file=sys.stderr)
        return 1
    except (ValueError, OSError, AcommError) as e:
        print("acomm bridge imc: %s" % e, file=sys.stderr)
        return 2
    gws = gateways(args, nodes)
    try:
        bridge = ImcBridge(gws, ticks_ms, advance, host=args.host, port=args.port, iface=args.iface,
                           group=None if args.no_multicast else ANNOUNCE_GROUP,
                           broadcast=None if args.broadcast == "none" else args.broadcast,
                           log=lambda t: print(t, file=sys.stderr, flush=True))
    except OSError as e:
        print("acomm bridge imc: %s" % e, file=sys.stderr)
        return 1
    systems = [{"name": gw.sys_name, "imc_id": gw.imc_id, "node_id": gw.node.node_id, "port": p}
               for gw, p in zip(gws, bridge.ports)]
    print(json.dumps({"systems": systems, "discovery_port": bridge.discovery_port, "multicast": bridge.multicast}),
          flush=True)
    signal.signal(signal.SIGTERM, interrupt)  # a supervisor's stop still prints the counters
    try:
        bridge.run(args.seconds)
    except KeyboardInterrupt:
        pass
    finally:
        bridge.close()
        report = {"bridge": bridge.stats, "systems": {gw.sys_name: dict(gw.stats, **gw.peers.stats) for gw in gws}}
        if world is not None:
            report["sim_ms"] = world.now()
        print(json.dumps(report), flush=True)
    return 0
