# `acomm node`: one acomm node on the command line, on real time, with any
# links: serial and Ethernet modems (--modem KIND:DEVICE, acomm_cpython.modems),
# UDP and TCP. It runs the same drivers, link layer and store-and-forward
# transport as the boards; --store DIR keeps the transport's packets on disk.
# --iridium directip:... / rockblock:... makes a shore node without a modem:
# its buoys' Iridium messages come from the gateway (acomm_cpython.shore).
#
# On standard input it takes console commands (acomm_cpython.console.console: send,
# file, range, cancel, status, help) and prints one line per event, or JSON
# lines with --json. The first lines say where each IP link listens and
# which modems are up, then "ready", so a script knows when to type.
#
# Exit status: 0 at the end (end of input, --seconds, Ctrl-C, SIGTERM); 2
# for a usage error (a wrong --modem KIND, a bad key file, a --store DIR
# that cannot be written); 1 when a modem cannot be opened or does not
# answer its start-up. A store whose disk fills up keeps the node running:
# new packets are refused (their final status says "store full") and one
# line says so, another when there is room again.

import sys

from acomm.apps.policy import commands
from acomm.frame.auth import Auth
from acomm.errors import AcommError, StoreError, StoreFull
from acomm.events import AVAILABLE
from acomm.link import BROADCAST
from acomm.node import Node
from acomm.wallclock import WallClock

from ..console import nodeloop
from ..modems import DRIVERS, ModemError, ModemSpecError, add_known, hostport, keyval, load_key, open_store, parse_value
from ..udp import DEFAULT_GROUP, DEFAULT_PORT


def add_arguments(p):
    p.add_argument("--name", required=True, help="this node's name")
    p.add_argument("--id", type=int, required=True, help="this node's id, 0..254 or 256..65534")
    p.add_argument("--known", action="append", default=[], metavar="NAME=ID", help="a node's name (else node-ID)")
    p.add_argument("--udp", metavar="[HOST:]PORT", help="a UDP link with its unicast socket here (0: any port)")
    p.add_argument("--group", default="%s:%d" % (DEFAULT_GROUP, DEFAULT_PORT), metavar="ADDR:PORT",
                   help="multicast group and port of the announcements (default %(default)s)")
    p.add_argument("--no-multicast", action="store_true", help="no multicast group")
    p.add_argument("--broadcast", default="255.255.255.255", metavar="ADDR",
                   help="also broadcast to ADDR on the group port ('none': do not)")
    p.add_argument("--iface", default="0.0.0.0", metavar="ADDR", help="interface address for multicast")
    p.add_argument("--peer", action="append", default=[], metavar="ID=HOST:PORT", help="a static UDP peer")
    p.add_argument("--tcp-listen", metavar="[HOST:]PORT", help="a TCP server link")
    p.add_argument("--tcp-connect", metavar="HOST:PORT", help="a TCP client link")
    p.add_argument("--modem", action="append", default=[], metavar="KIND:DEVICE[:BAUD]",
                   help="a modem link: KIND one of %s; DEVICE a serial port, tcp://HOST:PORT, "
                        "socket://HOST:PORT or rfc2217://HOST:PORT (repeat for more links)" % ", ".join(sorted(DRIVERS)))
    p.add_argument("--iridium", action="append", default=[], metavar="SERVICE:[HOST:]PORT[,KEY=VALUE...]",
                   help="a shore link to buoys through the Iridium gateway, no modem: directip:PORT[,mt=HOST:PORT]"
                        "[,imei=IMEI][,gateway=IP] or rockblock:PORT[,key=PEM][,mt=URL,credentials=FILE][,imei=IMEI] "
                        "(key: the JWT's public key, default the one Rock7 publishes; docs/drivers-iridium.md)")
    p.add_argument("--driver-option", action="append", default=[], metavar="KEY=VALUE",
                   help="an option of the modems' drivers (docs/drivers.md), e.g. cmd_timeout_ms=3000")
    p.add_argument("--advert-period", type=float, metavar="S",
                   help="seconds between adverts (default 10 on IP links, 60 on modems)")
    p.add_argument("--send", action="append", default=[], metavar="DST=TEXT",
                   help="send at start, once DST has been heard")
    nodeloop.add_console_arguments(p)
    p.add_argument("--key-file", metavar="PATH", help="the network key, 16 to 64 bytes as hex, in a file "
                   "(never on the command line, where ps shows it): frames are sealed and commands need a tag")
    p.add_argument("--tag-len", type=int, default=4, metavar="N", help="authentication tag bytes, 4..16 (default 4)")
    p.add_argument("--auth-counters", metavar="PATH", help="file keeping the authentication counters across restarts")
    p.add_argument("--auth-open", action="store_true",
                   help="open mode: with the key, take control frames (acks, SACKs, adverts) without a tag, as "
                        "before strict mode; anyone on the channel can then forge them (docs/wire-format.md)")


def _ip_links(args, node, out):
    # the UDP and TCP links asked for -> their ports
    from ..tcp import tcp_client_link, tcp_server_link
    from ..udp import udp_link

    period_ms = int((args.advert_period or 10.0) * 1000)
    ports = []
    if args.udp is not None:
        gaddr, gport = hostport(args.group)
        peers = {}
        for kv in args.peer:
            k, v = keyval(kv)
            peers[int(k)] = hostport(v, "127.0.0.1")
        link, port = udp_link(
            node,
            "udp",
            bind=hostport(args.udp),
            group=None if args.no_multicast else gaddr,
            group_port=gport,
            iface=args.iface,
            broadcast=None if args.broadcast == "none" else args.broadcast,
            peers=peers,
            advert_period_ms=period_ms,
        )
        ports.append(port)
        out.emit({"event": "listening", "link": "udp", "text": "udp on %s:%d" % port.address})
    if args.tcp_listen is not None:
        link, port = tcp_server_link(node, "tcp", bind=hostport(args.tcp_listen), advert_period_ms=period_ms)
        ports.append(port)
        out.emit({"event": "listening", "link": "tcp", "text": "tcp listening on %s:%d" % port.address})
    if args.tcp_connect is not None:
        host, p = hostport(args.tcp_connect, "127.0.0.1")
        name = "tcp" if args.tcp_listen is None else "tcp-out"
        link, port = tcp_client_link(node, host, p, name, advert_period_ms=period_ms)
        ports.append(port)
        out.emit({"event": "listening", "link": name, "text": "tcp connecting to %s:%d" % (host, p)})
    for i, spec in enumerate(args.iridium):
        from ..shore.spec import add_shore_link, link_name

        opts = {}
        if args.advert_period is not None:
            opts["advert_period_ms"] = int(args.advert_period * 1000)
        name = link_name(i)
        link, port = add_shore_link(node, spec, name, **opts)
        ports.append(port)
        out.emit({"event": "listening", "link": name, "text": "%s listening on %s:%d" % ((link.driver.service,) + tuple(port.address[:2]))})
    return ports


def _modem_links(args, node):
    # -> (streams, [(link name, kind, where, StartWatch)], {link: (kind, where)})
    from ..modems import add_modem_link, parse_spec

    opts = {}
    if args.advert_period is not None:
        opts["advert_period_ms"] = int(args.advert_period * 1000)
    dopts = dict((k, parse_value(v)) for k, v in (keyval(kv) for kv in args.driver_option))
    streams, watches, wheres = [], [], {}
    for spec in args.modem:
        kind, where, _ = parse_spec(spec)
        name, stream, watch = add_modem_link(node, spec, options=dopts, **opts)
        streams.append(stream)
        watches.append((name, kind, where, watch))
        wheres[name] = (kind, where)
    return streams, watches, wheres


def _send_when_heard(console, node, dst, text):
    # a --send message: sent once a link has heard dst (any link for "*");
    # -> False while none has
    for link in node.links.values():
        if dst == BROADCAST or link.availability(dst) == AVAILABLE:
            console.command("send %s %s --link %s%s" % (dst, text, link.name, "" if dst == BROADCAST else " --ack"))
            return True
    return False


def _store_lines(store, out):
    # store.put, watched: one line when the store first refuses a record
    # (its disk or its capacity is full), one when it takes one again; the
    # packets refused in between each get their own final status
    put = store.put
    full = [False]

    def watched(key, data):
        try:
            put(key, data)
        except StoreFull as e:
            if not full[0]:
                full[0] = True
                out.emit({"event": "store", "state": "full",
                          "text": "%s; new packets are refused until there is room" % e})
            raise
        if full[0]:
            full[0] = False
            out.emit({"event": "store", "state": "room", "text": "store %s: room again" % store.path})

    store.put = watched
    return store


_EPOCH_2020 = 1577836800  # time.time() at 2020-01-01 00:00 UTC: the wall clock's fixes count from there


def _clock_lines(node, out):
    # node.step, and a line each time the wall clock's source changes
    # ("none": the host's clock; "iridium", "gsm": a modem told the time)
    said = [node.wallclock.source]

    def step(now=None):
        r = node.step(now)
        wc = node.wallclock
        if wc.source != said[0]:
            said[0] = wc.source
            unc = wc.uncertainty_ms()
            out.emit({"event": "clock", "source": wc.source,
                      "text": "wall clock from %s (+-%d ms)" % (wc.source, unc or 0)})
        return r

    return step


def main(args):
    """`acomm node`: exit 0 at the end, 2 for a usage error, 1 when a link cannot be opened or started."""
    from ..hosttransport import HostTransport

    from ..console.console import Console
    from ..console.eventlines import Output

    if args.udp is None and args.tcp_listen is None and args.tcp_connect is None and not args.modem and not args.iridium:
        print("acomm node: give --modem, --iridium, --udp, --tcp-listen and/or --tcp-connect", file=sys.stderr)
        return 2
    try:
        for kv in args.send + args.known + args.driver_option:
            keyval(kv)
        from ..modems import parse_spec

        for spec in args.modem:
            parse_spec(spec)
        from ..shore.spec import parse_spec as parse_shore

        for spec in args.iridium:
            parse_shore(spec)
        key = load_key(args.key_file) if args.key_file is not None else None
        # the host's clock until a modem tells the time (AT-MSSTM, AT+CCLK?)
        node = Node(args.name, args.id, wallclock=WallClock(epoch_s=_EPOCH_2020))
        add_known(node, args.known)
        log = nodeloop.open_log(args.log)
    except (AcommError, ValueError) as e:
        print("acomm node: %s" % e, file=sys.stderr)
        return 2
    except OSError as e:
        print("acomm node: --log %s: %s" % (args.log, e.strerror or e), file=sys.stderr)
        return 2
    out = Output(sys.stdout, args.json, log)
    closers = []
    try:
        if key is not None:
            node.set_auth(Auth(key, args.tag_len, args.auth_counters, wall=node.wallclock.wall), commands(),
                          strict=not args.auth_open)
        ports = _ip_links(args, node, out)
        closers += ports
        streams, watches, wheres = _modem_links(args, node)
        closers += streams
        ports += streams  # what the loop waits on
        try:
            store = _store_lines(open_store(args.store), out) if args.store else None
        except (StoreError, OSError) as e:
            # a DIR that cannot be written: read-only, no permission, full
            why = e if isinstance(e, StoreError) else "store %s: %s" % (args.store, (e.strerror or str(e)).lower())
            print("acomm node: %s" % why, file=sys.stderr)
            return 2
        if store is not None:
            closers.append(store)
        transport = HostTransport.of(node, store=store, wall=node.wallclock.wall)
        if args.inbox:
            import os

            os.makedirs(args.inbox, exist_ok=True)
        console = Console(node, transport, out, args.lifespan, args.inbox, wheres)
        node.listen(console.on_event)
        pending = [keyval(m) for m in args.send]

        def send_pending():
            pending[:] = [m for m in pending if not _send_when_heard(console, node, m[0], m[1])]

        def never_heard():
            for dst, _ in pending:
                out.emit({"event": "error", "error": "not sent: %s was never heard" % dst})

        # typed lines, the --send list and the page's commands, one at a time
        return nodeloop.session("acomm node", args, node, out, console, _clock_lines(node, out), watches, ports, closers,
                                send_pending, after=never_heard)
    except ModemSpecError as e:
        print("acomm node: %s" % e, file=sys.stderr)
        return 2
    except (ModemError, AcommError, OSError) as e:
        print("acomm node: %s" % nodeloop.describe(e), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0  # while the links open
    finally:
        for c in closers:
            try:
                c.close()
            except OSError:
                pass
        if log is not None:
            log.close()
