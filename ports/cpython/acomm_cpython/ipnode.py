# `acomm node`: one acomm node on UDP and/or TCP links, on real time.
#
# It prints one line per event (received frames, availability, final
# statuses), sends the --send messages at start, and each line typed on
# standard input as "DESTINATION TEXT" ("*" for everyone; acknowledged when
# unicast). The first lines say where each link listens, so a script can
# start a client against a server bound to port 0.

import os
import select
import sys
import time

from acomm.auth import Auth
from acomm.errors import AcommError
from acomm.events import (AVAILABLE, AVAIL_NAMES, EV_AVAILABILITY, EV_RECEIVED, EV_REFUSED, EV_STATUS, STATUS_NAMES,
                          is_final)
from acomm.link import BROADCAST
from acomm.node import Node

from .tcp import tcp_client_link, tcp_server_link
from .udp import DEFAULT_GROUP, DEFAULT_PORT, udp_link


def hostport(text, default_host="0.0.0.0"):
    # "HOST:PORT", ":PORT" or "PORT" -> (host, port)
    host, _, port = text.rpartition(":")
    return (host or default_host, int(port))


def keyval(text):
    k, sep, v = text.partition("=")
    if not sep:
        raise ValueError("expected KEY=VALUE, got %r" % text)
    return k, v


def add_arguments(p):
    p.add_argument("--name", required=True, help="this node's name")
    p.add_argument("--id", type=int, required=True, help="this node's id, 0..254")
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
    p.add_argument("--advert-period", type=float, default=10.0, metavar="S", help="seconds between adverts")
    p.add_argument("--send", action="append", default=[], metavar="DST=TEXT", help="send at start")
    p.add_argument("--lifespan", type=float, default=30.0, metavar="S", help="lifespan of what is sent")
    p.add_argument("--seconds", type=float, help="stop after this long (default: at the end of standard input)")
    p.add_argument("--key-file", metavar="PATH", help="the network key, 16 to 64 bytes as hex, in a file "
                   "(never on the command line, where ps shows it): frames are sealed and commands need a tag")
    p.add_argument("--tag-len", type=int, default=4, metavar="N", help="authentication tag bytes, 4..16 (default 4)")
    p.add_argument("--auth-counters", metavar="PATH", help="file keeping the authentication counters across restarts")
    p.add_argument("--auth-open", action="store_true",
                   help="open mode: with the key, take control frames (acks, SACKs, adverts) without a tag, as "
                        "before strict mode; anyone on the channel can then forge them (docs/wire-format.md)")


def _print_event(ev):
    code = ev[0]
    if code == EV_RECEIVED:
        line = "received %s %s -> %s: %s" % (ev[1].name, ev[2], ev[3], bytes(ev[4]).decode("utf-8", "replace"))
        if len(ev) > 5 and not ev[5]:
            line += " (unauthenticated)"  # with a key: its frame had no valid tag
    elif code == EV_AVAILABILITY:
        line = "%s %s on %s" % ((AVAIL_NAMES[ev[3]] if 0 <= ev[3] < len(AVAIL_NAMES) else ev[3]), ev[2], ev[1].name)
    elif code == EV_REFUSED:
        line = "refused from %s: %s" % (ev[2], ev[3])
    elif code == EV_STATUS and is_final(ev[3]):
        line = "status %s %d %s%s" % (ev[1].name, ev[2], STATUS_NAMES[ev[3]], (": " + ev[4]) if ev[4] else "")
    else:
        return
    print(line, flush=True)


def _send(node, dst, text, lifespan):
    # On the first link where dst has been heard (any link for "*").
    # Returns False when no link reaches dst yet.
    for name, link in node.links.items():
        if dst == BROADCAST or link.availability(dst) == AVAILABLE:
            rid = node.send(name, dst, text.encode("utf-8"), lifespan, ack=dst != BROADCAST)
            print("sent %s %d to %s" % (name, rid, dst), flush=True)
            return True
    return False


def load_key(path):
    # -> the key bytes; AcommError naming the file and what is wrong with it
    # (the key itself never appears in a message). As ssh does with a
    # private key, a file that anyone but its owner may read or write is
    # refused: the key may already be out.
    try:
        mode = os.stat(path).st_mode
    except OSError as e:
        raise AcommError("key file %s: %s" % (path, e.strerror or e))
    if mode & 0o077:
        raise AcommError("key file %s: permissions %04o are too open: others than its owner can use it, so the key "
                         "may be known already; make it the owner's only (chmod 600 %s), or take a new key"
                         % (path, mode & 0o7777, path))
    try:
        with open(path) as f:
            text = f.read().strip()
    except OSError as e:
        raise AcommError("key file %s: %s" % (path, e.strerror or e))
    try:
        key = bytes.fromhex(text)
    except ValueError:
        raise AcommError("key file %s: not hex digits" % path) from None
    if not 16 <= len(key) <= 64:
        raise AcommError("key file %s: %d bytes, the key must be 16 to 64" % (path, len(key)))
    return key


def build(args):
    node = Node(args.name, args.id, listener=_print_event)
    if args.key_file is not None:
        node.set_auth(Auth(load_key(args.key_file), args.tag_len, args.auth_counters), strict=not args.auth_open)
    for kv in args.known:
        k, v = keyval(kv)
        node.names.add(k, int(v))
    period_ms = int(args.advert_period * 1000)
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
        print("udp on %s:%d" % port.address, flush=True)
    if args.tcp_listen is not None:
        link, port = tcp_server_link(node, "tcp", bind=hostport(args.tcp_listen), advert_period_ms=period_ms)
        ports.append(port)
        print("tcp listening on %s:%d" % port.address, flush=True)
    if args.tcp_connect is not None:
        host, p = hostport(args.tcp_connect, "127.0.0.1")
        name = "tcp" if args.tcp_listen is None else "tcp-out"
        link, port = tcp_client_link(node, host, p, name, advert_period_ms=period_ms)
        ports.append(port)
        print("tcp connecting to %s:%d" % (host, p), flush=True)
    return node, ports


def main(args):
    if args.udp is None and args.tcp_listen is None and args.tcp_connect is None:
        print("acomm node: give --udp, --tcp-listen and/or --tcp-connect", file=sys.stderr)
        return 2
    try:
        node, ports = build(args)
    except AcommError as e:
        print("acomm node: %s" % e, file=sys.stderr)
        return 2
    # --send messages wait until their destination has been heard
    pending = [keyval(m) for m in args.send]
    deadline = None if args.seconds is None else time.monotonic() + args.seconds
    stdin_open = True
    try:
        while deadline is None or time.monotonic() < deadline:
            node.step()
            pending = [m for m in pending if not _send(node, m[0], m[1], args.lifespan)]
            if not stdin_open:
                time.sleep(0.005)
                continue
            if not select.select([sys.stdin], [], [], 0.005)[0]:
                continue
            line = sys.stdin.readline()
            if not line:  # end of input: stop, unless running for --seconds
                if deadline is None:
                    break
                stdin_open = False
                continue
            dst, _, text = line.strip().partition(" ")
            if text and not _send(node, dst, text, args.lifespan):
                print("no link has heard %s" % dst, flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        for p in ports:
            p.close()
        for dst, _ in pending:
            print("not sent: %s was never heard" % dst, flush=True)
    return 0
