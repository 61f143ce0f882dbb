# The console of a node on the command line (`acomm node`, `acomm run`):
# one command per line, answered with dicts through an Output
# (acomm_cpython.console.eventlines), so the same session reads as text or as JSON
# lines. A line that does not parse is answered with one error and the
# node goes on.
#
#   send DST TEXT [--ack] [--priority N] [--lifespan S] [--link NAME]
#   file DST PATH [--priority N] [--lifespan S]    through the transport
#   range DST [--link NAME]
#   cancel ID                                       a send or range request
#   status                                          links, neighbours, queues, store, errors
#   help
#
# `send` is one frame on one link: the link named, else the first that has
# heard DST, else the first that can address it; `--ack` asks for an
# acknowledgement, so its final status is delivered or failed. `file` is a
# packet of the store-and-forward transport: fragmented, acknowledged
# selectively, kept in the store until it is final.

import os
import time
from collections import deque

from acomm.drivers.caps import CAP_RANGING
from acomm.errors import AcommError
from acomm.events import AVAILABLE, EV_AVAILABILITY, EV_PACKET, EV_PACKET_STATUS, EV_REFUSED, EV_STATUS
from acomm.link import BROADCAST

from ..hosttransport import progress
from .eventlines import as_dict

HELP = (
    "send DST TEXT [--ack] [--priority N] [--lifespan S] [--link NAME]   one frame (* for everyone)",
    "file DST PATH [--priority N] [--lifespan S]   a file through the transport (stored until delivered)",
    "range DST [--link NAME]                        measure the range to DST",
    "cancel ID                                      cancel a send or range request",
    "status                                         links, neighbours, queues, store, last errors",
    "alarm NAME, chat TEXT                          a board's station (acomm run): CADDY alarm or chat",
    "help                                           this list; Ctrl-C or Ctrl-D leaves",
)
_FILE_LIFESPAN_S = 3600.0
_ERRORS_KEPT = 5


class ConsoleError(Exception):
    pass


def _options(words, allowed):
    # -> (the words that are not options, {option: value}); flags get True
    rest, opts = [], {}
    i = 0
    while i < len(words):
        w = words[i]
        if w.startswith("--") and len(w) > 2:
            key = w[2:]
            if key not in allowed:
                raise ConsoleError("unknown option %s (allowed: %s)" % (w, ", ".join("--" + k for k in allowed)))
            conv = allowed[key]
            if conv is None:
                opts[key] = True
            else:
                if i + 1 >= len(words):
                    raise ConsoleError("%s needs a value" % w)
                try:
                    opts[key] = conv(words[i + 1])
                except ValueError:
                    raise ConsoleError("%s: not a number: %r" % (w, words[i + 1])) from None
                i += 1
        else:
            rest.append(w)
        i += 1
    return rest, opts


def _priority(opts, default=10):
    p = opts.get("priority", default)
    if not 1 <= p <= 16:
        raise ConsoleError("--priority: 1 (most urgent) to 16, not %d" % p)
    return p


def _lifespan(opts, default):
    s = opts.get("lifespan", default)
    if not 0 < s <= 86400 * 3:
        raise ConsoleError("--lifespan: seconds, more than 0 and at most 3 days")
    return s


class Console:
    """Runs console commands on a node; also the node's event listener (on_event).

    node: acomm.node.Node; transport: acomm.transport.Transport or None (then
    `file` is refused); out: eventlines.Output; inbox: a folder where whole
    packets that arrive are saved (None: not saved); wheres: {link name:
    (kind, device)} for the status report; station: the board's
    acomm.apps.station.Station (alarm, chat) or None."""

    def __init__(self, node, transport, out, lifespan_s=30.0, inbox=None, wheres=None, station=None):
        self.node = node
        self.station = station
        self.transport = transport
        self.out = out
        self.lifespan_s = lifespan_s
        self.inbox = inbox
        self.wheres = wheres or {}
        self.errors = deque(maxlen=_ERRORS_KEPT)
        self.heard = {}  # link name -> {node name: availability}, from the events
        self._progress = {}  # packet id -> (sent, acked) last shown
        # what this console asked for and is not final yet: ("link", request
        # id) and ("packet", packet id); the loop waits for them at the end
        # of input
        self.open = set()
        self._received = 0
        self.started = time.monotonic()

    # -- events ------------------------------------------------------------------
    def on_event(self, ev):
        """The node's listener: every event printed (and logged) as one dict."""
        code = ev[0]
        if code == EV_AVAILABILITY:
            self.heard.setdefault(ev[1].name, {})[ev[2]] = ev[3]
        d = as_dict(ev)
        if d is None:
            return
        if code == EV_PACKET:
            d["saved"] = self._save(ev[1], ev[3])
        if code == EV_PACKET_STATUS and d["final"]:
            self._progress.pop(ev[1], None)
            self.open.discard(("packet", ev[1]))
        if code == EV_STATUS and d["final"]:
            self.open.discard(("link", ev[2]))
        if code == EV_REFUSED or (d.get("final") and d["status"] in ("failed", "expired")):
            self.errors.append("%s: %s" % (time.strftime("%H:%M:%S"), as_text_short(d)))
        self.out.emit(d)

    def _save(self, src, data):
        if self.inbox is None:
            return None
        self._received += 1
        path = os.path.join(self.inbox, "%s-%d-%d.bin" % (src, int(time.time()), self._received))
        with open(path, "wb") as f:
            f.write(data)
        return path

    def error(self, text):
        self.out.emit({"event": "error", "error": text})

    # -- commands ------------------------------------------------------------------
    def command(self, line):
        """Runs one console line. Never raises: a bad line is answered with one error."""
        words = line.split()
        if not words:
            return
        verb = words[0]
        fn = getattr(self, "cmd_" + verb, None)
        if fn is None:
            self.error("unknown command %r (help lists them)" % verb)
            return
        try:
            fn(words[1:])
        except ConsoleError as e:
            self.error("%s: %s" % (verb, e))
        except (AcommError, ValueError) as e:
            self.error("%s: %s" % (verb, e))
        except OSError as e:
            self.error("%s: %s" % (verb, e.strerror or e))

    def _link_for(self, dst, opts, need=0):
        links = self.node.links
        if "link" in opts:
            if opts["link"] not in links:
                raise ConsoleError("no link %r (links: %s)" % (opts["link"], ", ".join(links)))
            return links[opts["link"]]
        usable = [lk for lk in links.values() if not need or lk.driver.caps.has(need)]
        if not usable:
            raise ConsoleError("no link can do that")
        for lk in usable:
            if dst != BROADCAST and lk.availability(dst) == AVAILABLE:
                return lk
        return usable[0]

    def _dst(self, name):
        # names come from --known (or a board's peers) and from nodes heard (node-N)
        if name != BROADCAST and self.node.names.id_of(name) is None:
            raise ConsoleError("unknown node %r (give --known NAME=ID)" % name)
        return name

    def cmd_send(self, words):
        rest, opts = _options(words, {"ack": None, "priority": int, "lifespan": float, "link": str})
        if len(rest) < 2:
            raise ConsoleError("usage: send DST TEXT [--ack] [--priority N] [--lifespan S] [--link NAME]")
        dst = self._dst(rest[0])
        data = " ".join(rest[1:]).encode("utf-8")
        ack = bool(opts.get("ack"))
        if ack and dst == BROADCAST:
            raise ConsoleError("--ack needs one destination, not *")
        prio = _priority(opts)
        life = _lifespan(opts, self.lifespan_s)
        link = self._link_for(dst, opts)
        rid = self.node.next_req_id()
        if not link.request(self.node.clock(), rid, dst, data, life, prio, ack):
            return  # refused: its final status (failed, with the reason) was printed
        self.open.add(("link", rid))
        self.out.emit({"event": "sent", "link": link.name, "id": rid, "dst": dst, "bytes": len(data),
                       "priority": prio, "ack": ack})

    def cmd_file(self, words):
        rest, opts = _options(words, {"priority": int, "lifespan": float})
        if len(rest) != 2:
            raise ConsoleError("usage: file DST PATH [--priority N] [--lifespan S]")
        if self.transport is None:
            raise ConsoleError("this node has no transport")
        dst = self._dst(rest[0])
        if dst == BROADCAST:
            raise ConsoleError("a file goes to one node, not *")
        with open(rest[1], "rb") as f:
            data = f.read()
        pid = self.transport.send(self.node.clock(), dst, data, _lifespan(opts, _FILE_LIFESPAN_S), _priority(opts))
        self._progress[pid] = None
        self.open.add(("packet", pid))
        self.out.emit({"event": "packet", "id": pid, "dst": dst, "bytes": len(data), "path": rest[1]})

    def cmd_range(self, words):
        rest, opts = _options(words, {"link": str})
        if len(rest) != 1:
            raise ConsoleError("usage: range DST [--link NAME]")
        dst = rest[0]
        if dst == BROADCAST:
            raise ConsoleError("range one node, not *")
        dst = self._dst(dst)
        link = self._link_for(dst, opts, CAP_RANGING)
        rid = self.node.next_req_id()
        self.out.emit({"event": "ranging", "link": link.name, "id": rid, "dst": dst})
        if link.range(self.node.clock(), rid, [dst], self.lifespan_s) is not False:
            self.open.add(("link", rid))

    def cmd_cancel(self, words):
        if len(words) != 1 or not words[0].isdigit():
            raise ConsoleError("usage: cancel ID (the number printed by send or range)")
        rid = int(words[0])
        now = self.node.clock()
        for link in self.node.links.values():
            if link.cancel(now, rid, "canceled at the console"):
                return  # its final status (canceled) follows as an event
        raise ConsoleError("no request %d waiting on any link" % rid)

    def _station(self):
        if self.station is None:
            raise ConsoleError("this node has no station (a board's, under acomm run)")
        return self.station

    def cmd_alarm(self, words):
        from acomm.catalog.caddy import ALARMS

        if len(words) != 1 or words[0] not in ALARMS:
            raise ConsoleError("usage: alarm NAME, NAME one of %s" % ", ".join(ALARMS))
        self._queued(self._station().alarm(self.node.clock(), words[0]), self.station.alarm_to, "alarm " + words[0])

    def cmd_chat(self, words):
        if not words:
            raise ConsoleError("usage: chat TEXT")
        st = self._station()
        self._queued(st.chat(self.node.clock(), " ".join(words)), st.report_to, "chat")

    def _queued(self, pid, dst, what):
        if pid is None:
            raise ConsoleError("the transport refused it (see status)")
        self._progress[pid] = None
        self.open.add(("packet", pid))
        self.out.emit({"event": "packet", "id": pid, "dst": dst, "what": what})

    def cmd_help(self, words):
        self.out.emit({"event": "help", "lines": list(HELP)})

    def cmd_status(self, words):
        self.out.emit(self.report())

    # -- the status report --------------------------------------------------------
    def report(self):
        """{"event": "report", "lines": [...], "links": [...], "store": {...}, "errors": [...]}"""
        node = self.node
        now = node.clock()
        up = int(time.monotonic() - self.started)
        lines = ["node %s (%d), up %d:%02d:%02d" % (node.name, node.node_id, up // 3600, up // 60 % 60, up % 60)]
        links = []
        for name, link in node.links.items():
            kind, where = self.wheres.get(name, (type(link.driver).__name__, "-"))
            classes = {}
            for req in link.queue:
                classes[req.priority] = classes.get(req.priority, 0) + 1
            neighbours = []
            for nname, state in sorted(self.heard.get(name, {}).items()):
                nid = node.names.id_of(nname)
                last = link.discovery.last_heard(nid) if nid is not None else None
                age = None if last is None else round((now - last) / 1000.0, 1)
                neighbours.append({"name": nname, "id": nid, "state": "available" if state == AVAILABLE else
                                   "unavailable", "age_s": age})
            ready = link.driver.ready(now)
            links.append({"name": name, "kind": kind, "where": where, "ready": ready, "queue": len(link.queue),
                          "queue_by_priority": dict((str(k), v) for k, v in sorted(classes.items())),
                          "neighbours": neighbours, "stats": dict(link.stats)})
            lines.append("link %s: %s on %s, %s, queue %d%s" % (
                name, kind, where, "ready" if ready else "busy or starting", len(link.queue),
                (" (" + ", ".join("p%d: %d" % kv for kv in sorted(classes.items())) + ")") if classes else ""))
            for n in neighbours:
                lines.append("  %s (%s) %s, heard %s" % (n["name"], n["id"], n["state"],
                                                          "never" if n["age_s"] is None else "%.0f s ago" % n["age_s"]))
            if not neighbours:
                lines.append("  no neighbour heard yet")
        store = self._store()
        if store is not None:
            lines.append("store: %d packets pending, %s" % (store["pending"], store["use"]))
        lines.append("stream errors: %d" % node.stream_errors)
        lines.append("last errors: " + ("none" if not self.errors else ""))
        lines.extend("  " + e for e in self.errors)
        return {"event": "report", "lines": lines, "node": node.name, "id": node.node_id, "links": links,
                "store": store, "errors": list(self.errors), "stream_errors": node.stream_errors}

    def _store(self):
        t = self.transport
        if t is None:
            return None
        s = t.store
        cap = getattr(s, "capacity_bytes", None)
        used = getattr(s, "used_bytes", None)
        if used is not None:
            use = "%d of %d bytes on disk (%s)" % (used, cap, getattr(s, "path", "?"))
        else:
            use = "in RAM (no --store)"
        return {"pending": len(t.pending()), "used_bytes": used, "capacity_bytes": cap, "use": use}

    # -- progress of the files being sent -------------------------------------------
    def poll(self):
        """Emits a progress event for each packet whose fragments sent or acknowledged changed.

        sent: fragments acknowledged plus those of the current round handed
        to the link; acked: acknowledged by the receiver (its SACKs come at
        the end of each round)."""
        t = self.transport
        if t is None or not self._progress:
            return
        for pid in list(self._progress):
            p = progress(t, pid)
            if p is not None and p[:2] != self._progress[pid]:
                self._progress[pid] = p[:2]
                self.out.emit({"event": "progress", "id": pid, "sent": p[0], "acked": p[1], "count": p[2]})


def as_text_short(d):
    # an error's line for the status report
    if d["event"] == "refused":
        return "refused from %s: %s" % (d["src"], d["reason"])
    what = ("%s %d" % (d["link"], d["id"])) if "link" in d else "packet %d" % d["id"]
    return "%s %s%s" % (what, d["status"], (": " + d["reason"]) if d.get("reason") else "")
