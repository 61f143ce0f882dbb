# The operator console's state, sans-IO: what a node's events say about the
# network (who is there and when each was last heard, USBL fixes and
# ranges, the message log with each request's status timeline, alarms
# until acknowledged, the transmit queues, link quality over the last hour),
# and the operator's commands turned into validated calls on the node. It
# imports no web library: acomm_web serves it over HTTP on CPython and on a
# MicroPython board; tests drive it with plain calls.
#
# Every collection is bounded: the log keeps log_size entries (LOG_SIZE by
# default), the alarms alarm_size (acknowledged ones go first), positions one fix and one range
# per node of the name table, quality one bucket per minute for an hour.
#
# Each view has a version number that changes when the view does, so a
# server pushes only what changed (versions()). Times in views are ages or
# countdowns in seconds, or seconds since the console started ("t"): the
# core has no wall clock.

from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError
from ..events import AVAIL_NAMES, STATUS_NAMES, is_final

# acomm.events' codes, as private constants (inlined: no module slot each)
_EV_STATUS = const(20)
_EV_RECEIVED = const(21)
_EV_AVAILABILITY = const(22)
_EV_CAPS = const(23)
_EV_RANGE_RECEIVED = const(24)
_EV_PACKET_STATUS = const(26)
_EV_PACKET = const(27)
_EV_REFUSED = const(28)
_QUEUED = const(1)
_DELIVERED = const(5)
_CANCELED = const(7)

LOG_SIZE = const(40)
ALARM_SIZE = const(16)
BUCKET_MS = const(60000)
BUCKETS = const(60)  # one hour of one-minute buckets
_OPEN_REQS = const(64)  # requests whose queueing time is kept for the latency

VIEWS = ("info", "nodes", "positions", "log", "alarms", "queue", "quality")




def _age_s(now, then):
    return None if then is None else ticks_diff(now, then) // 100 / 10


def _advert_period(disc, nid):
    # The advert period (ms) node nid announced, from Discovery's table
    # ([last heard, period, state] per node). Read here rather than through
    # a new Discovery method: one more method grows the class's dict on
    # every buoy, console or not (64 B of its heap, measured frozen).
    e = disc.nodes.get(nid)
    return None if e is None else e[1]


def _unwrap(driver):
    # a MAC wrapper (acomm.drivers.mac.MacDriver) keeps the modem's driver inside
    inner = getattr(driver, "driver", None)
    return inner if inner is not None else driver


def describe(values):
    """A message's values (dict, nested dicts) as one short line of text; one value alone, bare."""
    if len(values) == 1:
        for k in values:
            v = values[k]
            if not isinstance(v, dict):
                return "%.1f" % v if isinstance(v, float) else str(v)
    parts = []
    for k in sorted(values):  # MicroPython's dicts keep no order

        v = values[k]
        if isinstance(v, dict):
            v = "(" + describe(v) + ")"
        elif isinstance(v, float):
            v = "%.1f" % v
        parts.append("%s %s" % (k, v))
    return ", ".join(parts)


class ConsoleState:
    """The console's picture of the network, fed by a node's events; commands become node calls."""

    def __init__(self, node, catalogs=("caddy",), alarm_classes=("alarm",), lifespan_s=120, priority=3,
                 log_size=LOG_SIZE, alarm_size=ALARM_SIZE):
        # log_size, alarm_size: a board's heap may want fewer (about 0.3 KiB
        # an entry on a 32-bit port: acomm bench web)
        self.node = node
        self.log_size = log_size
        self.alarm_size = alarm_size
        self.catalogs = []
        for name in catalogs:
            from ..catalog import load

            self.catalogs.append(load(name))
        self.alarm_classes = alarm_classes
        self.lifespan_s = lifespan_s
        self.priority = priority
        self.t0 = node.clock()
        self._v = {}
        for k in VIEWS:
            self._v[k] = 1
        self.log = []  # entries: dicts, oldest first
        self._log_n = 0
        self._by_req = {}  # (link name, req id) -> log entry, while in the log
        self.alarms = []
        self._alarm_n = 0
        self.fixes = {}  # name -> [ms, east m, north m, depth m or None, source]
        self.ranges = {}  # name -> [ms, metres]
        self._fix_seen = {}  # link name -> the driver's last fix object, to see a new one
        self._heard = {}  # (link, name) -> last heard ms, to notice a change
        self._queued = {}  # (link name, req id) -> ms queued, for the latency
        self._qorder = []
        self._buckets = []  # [start ms, acked finals, delivered, latency ms sum, latency n, retries]
        self._retries = None
        self.refused = 0  # frames the node's key check refused (EV_REFUSED)
        self.commands = 0
        self.rejected = 0  # commands answered with a 4xx
        self.errors = 0  # events the console failed on (its server's tee counts them)
        self.last_error = None

    # -- bookkeeping -----------------------------------------------------------
    def bump(self, view):
        """Marks a view changed (its version moves on)."""
        self._v[view] += 1

    def versions(self):
        """{view: version}: a view's number changes whenever the view does."""
        return self._v

    def held(self):
        """Sizes of the bookkeeping kept beside the views, each bounded: requests, queueing times, buckets."""
        return {"requests": len(self._by_req), "queued": len(self._queued), "buckets": len(self._buckets)}

    def t_s(self, now):
        """Seconds (0.1 s steps) since the console started, of ticks now."""
        return ticks_diff(now, self.t0) // 100 / 10

    def _bucket(self, now):
        b = self._buckets
        if not b or ticks_diff(now, b[-1][0]) >= BUCKET_MS:
            start = now if not b else ticks_add(b[-1][0], ticks_diff(now, b[-1][0]) // BUCKET_MS * BUCKET_MS)
            b.append([start, 0, 0, 0, 0, 0])
            if len(b) > BUCKETS:
                b.pop(0)
        return b[-1]

    def add_log(self, now, direction, cls, peer, text, link=None, req=None, by=None):
        """A new log entry (dict; direction rx, tx or op); a request's statuses will join its timeline."""
        self._log_n += 1
        e = {"id": self._log_n, "t": self.t_s(now), "dir": direction, "cls": cls, "peer": peer, "text": text,
             "link": link, "req": req, "by": by, "status": None, "timeline": []}
        self.log.append(e)
        if len(self.log) > self.log_size:
            old = self.log.pop(0)
            if old["req"] is not None:
                self._by_req.pop((old["link"], old["req"]), None)
        if req is not None:
            self._by_req[(link, req)] = e
        self.bump("log")
        return e

    # -- events in ---------------------------------------------------------------
    def sent(self, now, link, req_id, dst, cls, text, by=None):
        """Notes a request another application made (so its statuses show in the log)."""
        e = self.add_log(now, "tx", cls, dst, text, link, req_id, by)
        q = self._queued.get((link, req_id))
        if q is not None:  # its `queued` came before the application could tell us
            e["status"] = "queued"
            e["timeline"].append([self.t_s(q), "queued"])
        return e

    def on_event(self, ev, now=None):
        """A node event (acomm.events); the node's listener, or teed from it."""
        if now is None:
            now = self.node.clock()
        code = ev[0]
        if code == _EV_STATUS:
            self._status(now, ev[1].name, ev[2], ev[3], ev[4])
        elif code == _EV_RECEIVED:
            self._received(now, ev[1].name, ev[2], ev[4], len(ev) > 5 and ev[5])
        elif code == _EV_PACKET:
            self._received(now, "transport", ev[1], ev[3], len(ev) > 4 and ev[4])
        elif code == _EV_PACKET_STATUS:
            self._status(now, "transport", ev[1], ev[2], ev[3])
        elif code == _EV_AVAILABILITY:
            self.bump("nodes")
        elif code == _EV_CAPS:
            self.bump("info")
        elif code == _EV_RANGE_RECEIVED:
            names, metres = ev[3], ev[4]
            for i in range(len(names)):
                if metres[i] is not None:
                    self.ranges[names[i]] = [now, metres[i]]
            self.bump("positions")
        elif code == _EV_REFUSED:
            self.refused += 1
            self.add_log(now, "rx", "refused", ev[2], ev[3], ev[1].name if ev[1] is not None else None)

    def _status(self, now, link, req, status, reason):
        key = (link, req)
        if status == _QUEUED:
            self._queued[key] = now
            self._qorder.append(key)
            if len(self._qorder) > _OPEN_REQS:
                self._queued.pop(self._qorder.pop(0), None)
            self.bump("queue")
        e = self._by_req.get(key)
        if e is not None:
            name = STATUS_NAMES[status] if 0 < status < len(STATUS_NAMES) else str(status)
            e["status"] = name
            e["timeline"].append([self.t_s(now), name])
            if reason:
                e["reason"] = reason
            self.bump("log")
        if is_final(status):
            self.bump("queue")
            t0 = self._queued.pop(key, None)
            if status >= _DELIVERED and status != _CANCELED:
                # PDR: delivered / (delivered + expired + failed); a one-way
                # frame's `transmitted` says nothing about delivery, and an
                # operator's cancel is no fault of the link
                b = self._bucket(now)
                b[1] += 1
                if status == _DELIVERED:
                    b[2] += 1
                    if t0 is not None:
                        b[3] += ticks_diff(now, t0)
                        b[4] += 1
                self.bump("quality")

    def decode(self, data):
        """(class, text) of a payload: the first catalog that parses it, else ("data", hex)."""
        for cat in self.catalogs:
            try:
                msgs = cat.unpack(data)
            except AcommError:
                continue
            if msgs:
                m, values = msgs[0]
                return m.name, describe(values)
        return "data", bytes(data[:16]).hex() + ("..." if len(data) > 16 else "")

    def _received(self, now, link, src, data, authed):
        cls, text = self.decode(data)
        e = self.add_log(now, "rx", cls, src, text, link)
        e["sealed"] = bool(authed)
        if cls in self.alarm_classes:
            self._alarm_n += 1
            self.alarms.append({"id": self._alarm_n, "t": self.t_s(now), "from": src, "text": text,
                                "acked_by": None, "acked_t": None})
            if len(self.alarms) > self.alarm_size:
                # the oldest acknowledged one goes first, else the oldest
                k = 0
                for i in range(len(self.alarms)):
                    if self.alarms[i]["acked_by"] is not None:
                        k = i
                        break
                self.alarms.pop(k)
            self.bump("alarms")

    def poll(self, now):
        """Notices what no event announces: new USBL fixes, last-heard times, retries."""
        node = self.node
        for lname in node.links:
            link = node.links[lname]
            fix = getattr(_unwrap(link.driver), "last_fix", None)
            if fix is not None and fix is not self._fix_seen.get(lname):
                self._fix_seen[lname] = fix
                self._take_fix(now, link, fix)
            disc = link.discovery
            for nid in disc.available():
                name = node.names.name_of(nid)
                h = disc.last_heard(nid)
                if self._heard.get((lname, name)) != h:
                    if len(self._heard) < 4 * len(node.names) + 8:
                        self._heard[(lname, name)] = h
                    self.bump("nodes")
        r = 0
        for lname in node.links:
            r += node.links[lname].stats.get("retries", 0)
        if self._retries is not None and r != self._retries:
            self._bucket(now)[5] += r - self._retries
            self.bump("quality")
        self._retries = r

    def _take_fix(self, now, link, fix):
        # a SeaTrac ACO_FIX (acomm.drivers.seatrac_wire.fix_dict): with a
        # position, the remote beacon relative to ours, metres east and
        # north; with a range only, a circle
        nid = link.addr_map.id_of(fix.get("src"))
        if nid is None:
            return
        name = self.node.names.name_of(nid)
        if "easting" in fix:
            self.fixes[name] = [now, fix["easting"], fix["northing"], fix.get("depth"), "usbl"]
        if fix.get("range") is not None:
            self.ranges[name] = [now, fix["range"]]
        self.bump("positions")

    # -- views -------------------------------------------------------------------
    def view(self, name, now):
        """One view (a name of VIEWS) as plain dicts and lists; KeyError for another name."""
        if name == "info":
            return self._info()
        if name == "nodes":
            return self._nodes(now)
        if name == "positions":
            return self._positions(now)
        if name == "log":
            return {"entries": self.log}
        if name == "alarms":
            return {"alarms": self.alarms, "unacked": len([a for a in self.alarms if a["acked_by"] is None])}
        if name == "queue":
            return self._queue(now)
        if name == "quality":
            return self._quality(now)
        raise KeyError(name)

    def _info(self):
        node = self.node
        links = []
        for lname in node.links:
            c = node.links[lname].caps
            links.append({"name": lname, "model": ("%s %s" % (c.manufacturer, c.model)).strip(), "mtu": c.mtu_tx,
                          "bitrate": c.bitrate, "latency_ms": c.latency_ms, "caps": c.flag_names()})
        return {"name": node.name, "id": node.node_id, "links": links, "sealed": node.auth is not None,
                "catalogs": [c.name for c in self.catalogs], "errors": self.errors, "last_error": self.last_error}

    def _nodes(self, now):
        node = self.node
        out = []
        for name in node.names.names():
            nid = node.names.id_of(name)
            row = {"name": name, "id": nid, "self": name == node.name, "links": []}
            for lname in node.links:
                disc = node.links[lname].discovery
                state = disc.state(nid)
                if state == 0 and name != node.name:
                    continue
                period = _advert_period(disc, nid)
                row["links"].append({"link": lname, "state": AVAIL_NAMES[state],
                                     "heard_s": _age_s(now, disc.last_heard(nid)),
                                     "period_s": None if period is None else period // 1000})
            out.append(row)
        return {"nodes": out}

    def _positions(self, now):
        out = {}
        for name in self.fixes:
            f = self.fixes[name]
            out[name] = {"east": f[1], "north": f[2], "depth": f[3], "source": f[4], "age_s": _age_s(now, f[0])}
        rng = {}
        for name in self.ranges:
            r = self.ranges[name]
            rng[name] = {"metres": r[1], "age_s": _age_s(now, r[0])}
        return {"origin": self.node.name, "fixes": out, "ranges": rng}

    def _queue(self, now):
        links = []
        for lname in self.node.links:
            link = self.node.links[lname]
            items = []
            for r in link.queue:
                e = self._by_req.get((lname, r.req_id))
                items.append({"req": r.req_id, "priority": r.priority, "bytes": len(r.data),
                              "dst": None if r.dst is None else self.node.names.name_of(r.dst),
                              "cls": e["cls"] if e is not None else "p%d" % r.priority,
                              "expires_s": ticks_diff(r.deadline, now) // 100 / 10})
            links.append({"link": lname, "capacity": link.queue.capacity, "items": items})
        t = self.node.transport
        store = None
        if t is not None:
            # the transport's packets on their way out, from its list of
            # them (no public accessor yet); expiry is in its wall seconds
            wall = t.wall()
            store = []
            for p in getattr(t, "_out", ()):
                store.append({"pid": p.pid, "dst": self.node.names.name_of(p.final), "priority": p.prio,
                              "bytes": p.size, "relayed": p.relayed, "cls": "p%d" % p.prio,
                              "expires_s": p.expiry - wall})
        return {"links": links, "transport": store}

    def _quality(self, now):
        rows = []
        for b in self._buckets:
            if ticks_diff(now, b[0]) >= BUCKET_MS * BUCKETS:
                continue
            rows.append({"t": self.t_s(b[0]), "acked": b[1], "pdr": None if not b[1] else round(b[2] / b[1], 3),
                         "latency_s": None if not b[4] else round(b[3] / b[4] / 1000, 1), "retries": b[5]})
        return {"bucket_s": BUCKET_MS // 1000, "buckets": rows}

    # -- operator commands in ----------------------------------------------------
    def command(self, now, cmd, who="operator"):
        """An operator command (a dict, e.g. parsed JSON) -> (HTTP code, answer dict); never raises.

        Ops: chat {dst, text}, command {dst, catalog caddy|seaware, name},
        cancel {req, link}, range {dst}, ack {alarm}. 202 with the request
        id when queued on the node, 200 when done, a 4xx with a reason when
        refused (acomm.apps.consolecmd)."""
        from .consolecmd import execute

        return execute(self, now, cmd, who)
