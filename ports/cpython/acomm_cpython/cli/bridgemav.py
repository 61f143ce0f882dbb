# `acomm bridge mavlink` (docs/mavlink.md): ArduSub teleoperation through
# acoustic modems, one process at each end.
#
#   vehicle side  --vehicle URL: the autopilot's MAVLink (the bridge is its
#                 ground station); the acoustic link to the topside
#   topside side  --gcs URL (default udpout:127.0.0.1:14550, where
#                 QGroundControl listens): the bridge is the GCS's vehicle
#
# Both take their links as `acomm node` does and need the network key:
# sticks, keep-alives and commands travel sealed. The first line is
# "ready" (with the MAVLink port actually bound); then one line per thing
# worth knowing; at the end (--seconds, Ctrl-C, SIGTERM) one JSON line of
# counters. --json prints every line as JSON; --log FILE appends them too.

import asyncio
import json
import signal
import sys
import time

from acomm.errors import AcommError

from ..modems import ModemError, ModemSpecError, keyval


def add_arguments(p):
    p.add_argument("--vehicle", metavar="URL", help="the vehicle side: the autopilot's MAVLink connection "
                   "(serial:/dev/ttyACM0:115200, udpin:0.0.0.0:14551, udpout:HOST:PORT, tcp:HOST:PORT)")
    p.add_argument("--gcs", metavar="URL", help="the topside side: where the ground station is (default "
                   "udpout:127.0.0.1:14550, QGroundControl's own port; udpin:HOST:PORT to listen instead)")
    p.add_argument("--allow-remote-gcs", action="store_true",
                   help="let --gcs listen beyond loopback (whoever reaches that port drives the vehicle)")
    p.add_argument("--name", help="this bridge's acomm node name (default: vehicle or topside)")
    p.add_argument("--id", type=int, help="this bridge's acomm node id (default: 2 vehicle, 1 topside)")
    p.add_argument("--peer", metavar="NAME=ID", help="the other bridge's acomm node (default topside=1 or vehicle=2)")
    p.add_argument("--modem", action="append", default=[], metavar="KIND:DEVICE[:BAUD]",
                   help="a modem link, as for acomm node (repeat for more links)")
    p.add_argument("--udp", metavar="[HOST:]PORT", help="a UDP link (a tether or a surface radio)")
    p.add_argument("--tcp-listen", metavar="[HOST:]PORT", help="a TCP server link")
    p.add_argument("--tcp-connect", metavar="HOST:PORT", help="a TCP client link")
    p.add_argument("--key-file", required=True, metavar="PATH",
                   help="the network key (hex, in a file only its owner reads): sticks and commands are sealed")
    p.add_argument("--json", action="store_true", help="print JSON lines")
    p.add_argument("--log", metavar="FILE", help="append every line to FILE as JSON, with its time")
    p.add_argument("--seconds", type=float, help="stop after this long")
    p.add_argument("--startup-timeout", type=float, default=15.0, metavar="S")
    v = p.add_argument_group("vehicle side")
    v.add_argument("--failsafe-timeout", type=float, metavar="S",
                   help="neutral sticks when nothing valid arrived for this long (default 7.5, 10 on a SeaTrac)")
    v.add_argument("--failsafe-action", default="neutral", choices=["neutral", "hold", "surface", "disarm"],
                   help="what else to do when the failsafe trips (hold: ALT_HOLD mode)")
    v.add_argument("--manual-hz", type=float, default=10.0, help="MANUAL_CONTROL rate to the autopilot (default 10)")
    v.add_argument("--telemetry", type=float, default=10.0, metavar="S",
                   help="period of the state when no topside polls (default 10)")
    t = p.add_argument_group("topside side")
    t.add_argument("--sysid", type=int, default=1, help="the MAVLink system id shown to the GCS (default 1)")
    t.add_argument("--threshold", type=float, default=0.1,
                   help="send sticks when an axis moved more than this (of full scale; default 0.1)")
    t.add_argument("--keepalive", type=float, metavar="S",
                   help="keep-alive period (default 3; 4 on a SeaTrac, whose packets take over a second)")
    t.add_argument("--poll", type=float, default=10.0, metavar="S",
                   help="ask the vehicle for its state this often (default 10)")
    t.add_argument("--reply-wait", type=float, metavar="S",
                   help="after a poll or command, sticks wait this long for the answer (default 2, 3 on a SeaTrac)")
    t.add_argument("--stick-gap", type=float, default=0.5, metavar="S",
                   help="at least this long between stick messages (default 0.5)")
    t.add_argument("--stale", type=float, default=25.0, metavar="S",
                   help="telemetry older than this is marked stale, not repeated (default 25)")
    t.add_argument("--command-timeout", type=float, default=20.0, metavar="S",
                   help="COMMAND_ACK FAILED when the vehicle has not answered in this long (default 20)")


class Lines:
    # what the bridge says: text or JSON lines on stdout, JSON in --log
    def __init__(self, json_lines, log):
        self.json = json_lines
        self.log = log

    def __call__(self, d):
        if self.log is not None:
            self.log.write(json.dumps(dict(d, t=round(time.time(), 3))) + "\n")
            self.log.flush()
        if self.json:
            print(json.dumps(d), flush=True)
        elif d["event"] == "bridge":
            print(d["text"], flush=True)
        else:
            print("%s %s" % (d["event"], json.dumps(dict((k, v) for k, v in d.items() if k != "event"))), flush=True)


def link_defaults(modems):
    """(keep-alive s, failsafe timeout s, reply wait s) for the links: a SeaTrac's packets take
    1.3 to 2 s (100 bit/s), so its keep-alive must leave room for the vehicle's answers."""
    if any(m.split(":", 1)[0] == "seatrac" for m in modems):
        return 4.0, 10.0, 3.0
    return 3.0, 7.5, 2.0  # a 200 bit/s modem's poll and state (docs/mavlink.md has the rule)


def main(args):
    from ..bridges.mavio import open_connection, parse_url

    vehicle = args.vehicle is not None
    if vehicle and args.gcs is not None:
        print("acomm bridge mavlink: --vehicle or --gcs, not both (one bridge per end)", file=sys.stderr)
        return 2
    if not (args.modem or args.udp or args.tcp_listen or args.tcp_connect):
        print("acomm bridge mavlink: give --modem, --udp, --tcp-listen and/or --tcp-connect", file=sys.stderr)
        return 2
    url = args.vehicle if vehicle else (args.gcs or "udpout:127.0.0.1:14550")
    keepalive, timeout, reply = link_defaults(args.modem)
    args.keepalive = args.keepalive if args.keepalive is not None else keepalive
    args.failsafe_timeout = args.failsafe_timeout if args.failsafe_timeout is not None else timeout
    args.reply_wait = args.reply_wait if args.reply_wait is not None else reply
    name = args.name or ("vehicle" if vehicle else "topside")
    node_id = args.id if args.id is not None else (2 if vehicle else 1)
    try:
        peer, peer_id = keyval(args.peer) if args.peer else (("topside", "1") if vehicle else ("vehicle", "2"))
        peer_id = int(peer_id)
        parse_url(url)
        from ..bridges import mavwire  # noqa: F401 (ImportError, saying what to install, without pymavlink)
    except ImportError as e:
        print("acomm bridge mavlink: %s" % e, file=sys.stderr)
        return 1
    except ValueError as e:
        print("acomm bridge mavlink: %s" % e, file=sys.stderr)
        return 2
    try:
        log = open(args.log, "a") if args.log else None
    except OSError as e:
        print("acomm bridge mavlink: --log %s: %s" % (args.log, e.strerror or e), file=sys.stderr)
        return 2
    emit = Lines(args.json, log)
    try:
        conn = open_connection(url)
    except (OSError, ValueError) as e:
        print("acomm bridge mavlink: %s: %s" % (url, e), file=sys.stderr)
        return 1
    if not vehicle and conn.listens_beyond_loopback() and not args.allow_remote_gcs:
        conn.close()
        print("acomm bridge mavlink: %s listens beyond loopback, and whoever reaches it drives the vehicle: "
              "add --allow-remote-gcs if that is meant" % url, file=sys.stderr)
        return 2
    try:
        return asyncio.run(_serve(args, vehicle, url, conn, name, node_id, peer, peer_id, emit))
    except KeyboardInterrupt:
        return 0
    finally:
        conn.close()
        if log is not None:
            log.close()


async def _serve(args, vehicle, url, conn, name, node_id, peer, peer_id, emit):
    from acomm.compat import ticks_ms
    from acomm.link.guard import Guard
    from acomm.apps.policy import commands
    from acomm.catalog import rovcontrol

    from ..bridges.mavbridge import BridgeRunner
    from ..bridges.mavwire import GCS_COMPONENT, GCS_SYSID, MavEndpoint
    from ..opennode import open_node

    # the seed catalogs' commands and this catalog's sticks, keep-alives and commands need a tag
    guard = Guard(commands().checks + (rovcontrol.guard_check,))
    try:
        async with open_node(name, node_id, modems=args.modem, udp=args.udp, tcp_listen=args.tcp_listen,
                             tcp_connect=args.tcp_connect, known={peer: peer_id}, key_file=args.key_file,
                             guard=guard, transport=False, startup_timeout_s=args.startup_timeout) as node:
            now = ticks_ms()
            if vehicle:
                from ..bridges.mavvehicle import VehicleSide

                endpoint = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
                side = VehicleSide(endpoint.mav, now, timeout_ms=int(args.failsafe_timeout * 1000),
                                   manual_ms=max(20, int(1000 / args.manual_hz)), action=args.failsafe_action,
                                   telemetry_ms=int(args.telemetry * 1000))
            else:
                from ..bridges.mavtopside import TopsideSide
                from ..bridges.mavwire import AUTOPILOT_COMPONENT

                endpoint = MavEndpoint(args.sysid, AUTOPILOT_COMPONENT)
                side = TopsideSide(endpoint.mav, now, threshold=args.threshold,
                                   keepalive_ms=int(args.keepalive * 1000), stick_gap_ms=int(args.stick_gap * 1000),
                                   stale_ms=int(args.stale * 1000), command_timeout_ms=int(args.command_timeout * 1000),
                                   reply_ms=int(args.reply_wait * 1000), poll_ms=int(args.poll * 1000),
                                   command_poll_ms=int(2 * args.reply_wait * 1000))
            runner = BridgeRunner(side, node, conn, endpoint, peer, emit)
            ready = {"event": "ready", "side": "vehicle" if vehicle else "topside", "node": name, "id": node_id,
                     "peer": peer, "mavlink": url, "links": node.links}
            if hasattr(conn, "port"):
                ready["mavlink_port"] = conn.port
            emit(ready)
            task = asyncio.get_running_loop().create_task(runner.run(args.seconds))
            loop = asyncio.get_running_loop()
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, runner.stop)
            try:
                await task
            except asyncio.CancelledError:
                pass
            finally:
                for sig in (signal.SIGINT, signal.SIGTERM):
                    loop.remove_signal_handler(sig)
                emit({"event": "stats", "side": side.stats, "bridge": runner.stats, "not_sent": runner.failures, "mavlink": endpoint.stats,
                      "mavlink_dropped": conn.dropped, "refused": dict(node.core.guard.refused)
                      if getattr(node.core, "guard", None) is not None else {}})
    except ModemSpecError as e:
        print("acomm bridge mavlink: %s" % e, file=sys.stderr)
        return 2
    except (ModemError, AcommError, OSError) as e:
        print("acomm bridge mavlink: %s" % e, file=sys.stderr)
        return 1
    return 0
