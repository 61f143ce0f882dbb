# The Node: one system on the network. It owns its links and the name table,
# moves bytes between each link and its byte stream, and passes every link
# event to its listeners (each gets every event, in the order they were
# added; with none, events wait in a bounded backlog). Time is injected: step(now) does one round of work
# at the given time (the simulator calls it on virtual time); run() loops on
# asyncio with the node's clock (the ports use it on real time).
#
# A stream is any object with read(n) -> bytes or None/b"" when nothing is
# waiting, and write(bytes): machine.UART, acomm_sim.fakeuart.FakeUART, or the
# CPython port's serial and socket adapters. A port that moves whole frames
# to and from endpoints (UDP, TCP: acomm.drivers.datagram) has pump(now)
# instead: it feeds the driver what arrived and sends what the driver has,
# and the node calls it before and after each poll of the link.
#
# Wall clock: a node given one (acomm.wallclock.WallClock, `wallclock`)
# feeds it the times its drivers read (AT-MSSTM, AT+CCLK?: each driver with
# take_times()) and those of other time sources (add_time_source: a GPS
# reader on its own UART), and polls it every step; the ports hand its
# wall() to the key (Auth) and the transport. The times are not given to
# the listeners.

from .compat import const, ticks_ms
from .link import Link
from .link.names import NameTable

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_SEGMENT = const(25)
_EV_CONTROL = const(29)
_EV_STATUS = const(20)
_LINK = const(1)
_REQ_ID = const(2)
_STATUS = const(3)
_REASON = const(4)
_SEG_SRC = const(2)
_SEG_DST = const(3)
_SEG_HEAD = const(4)
_SEG_PAYLOAD = const(5)
_SEG_AUTHED = const(6)

_TIME_AT = const(5)  # acomm.events: EV_TIME's ticks

_READ_CHUNK = const(256)
_EVENT_BACKLOG = const(64)
_READS_PER_STEP = const(16)


class Node:
    """One system on the network: its name and id (0..254), links, name table; every event to its listeners."""

    # absent unless given (class defaults: no slot on a board's instance)
    wallclock = None  # acomm.wallclock.WallClock
    _timed = ()  # ((time source, its stream or None), ...)

    def __init__(self, name, node_id, clock=None, names=None, listener=None, wallclock=None):
        """clock() -> ticks in ms (default: the runtime's); listener(ev), if given, is the first listener;
        wallclock: the acomm.wallclock.WallClock its drivers' times set."""
        self.name = name
        self.node_id = node_id
        self.clock = clock if clock is not None else ticks_ms
        self.names = names if names is not None else NameTable()
        self.names.add(name, node_id)
        self.listeners = [listener] if listener is not None else []
        self.links = {}
        # link name -> [its stream, the frame port's pump or None, bytes a
        # short write left behind]: one dict, not three (a board's heap)
        self._io = {}
        self._req_id = 0
        self.auth = None  # acomm.frame.auth.Auth: set_auth()
        self.guard = None
        # Without a listener, events wait here for the application to take
        # them; bounded: the oldest are dropped (and counted) beyond the cap.
        self.backlog = []
        self.backlog_dropped = 0
        # reads and writes that raised OSError (an unplugged USB adapter, a
        # UART error): the link goes on without those bytes
        self.stream_errors = 0
        # reads that brought bytes and writes that took some, for ever: a
        # board's loop (acomm_mp.runloop) steps an idle node less often and
        # tells idle from busy by whether a step moved this
        self.moved = 0
        # the transport (acomm.transport.Transport, attach()): it gets the
        # links' SEGMENT frames and the statuses of its own requests
        self.transport = None
        self._now = 0
        if wallclock is not None:
            self.wallclock = wallclock

    def set_auth(self, auth, guard=None, strict=True):
        """A network key (acomm.frame.auth.Auth) for every link, present and future, and the
        command policy (an acomm.link.guard.Guard, e.g. acomm.apps.policy.commands()) of what
        needs a valid tag. Without a guard only key commands need one; strict mode (default)
        also refuses unsealed control frames, strict=False is open mode. auth=None removes both."""
        if auth is not None and guard is None:
            from .link.guard import Guard

            guard = Guard(())
        if guard is not None:
            guard.strict = strict
        self.auth = auth
        self.guard = guard if auth is not None else None
        for name in self.links:
            self._secure(self.links[name])
        if self.transport is not None:
            self.transport.guard = self.guard
            self.transport.auth = auth

    def attach(self, transport):
        """Makes transport (acomm.transport.Transport) this node's: it gets the links' segments and
        its requests' statuses, is polled by step(), and shares the node's key and command policy."""
        self.transport = transport
        transport.guard = self.guard
        transport.auth = self.auth

    def listen(self, fn):
        """Adds fn(ev) to the listeners: it gets every event from now on, after those added before."""
        self.listeners.append(fn)

    def unlisten(self, fn):
        """Removes fn from the listeners (nothing when it is not one)."""
        if fn in self.listeners:
            self.listeners.remove(fn)

    def _secure(self, link):
        link.framing.set_auth(self.auth)
        link.guard = self.guard

    def add_link(self, name, driver, stream=None, **options):
        """Adds a Link over the sans-IO driver, moving bytes to and from stream; -> the Link."""
        link = Link(name, driver, self.node_id, self.names, self._on_event, **options)
        if self.auth is not None:
            self._secure(link)
        self.links[name] = link
        self._io[name] = [stream, getattr(stream, "pump", None) if stream is not None else None, b""]
        if getattr(driver, "take_times", None) is not None:
            self.add_time_source(driver)
        return link

    def add_time_source(self, source, stream=None):
        """A source of times for the wall clock: source.take_times() -> EV_TIME tuples each step; with a
        stream, the node reads it and gives the bytes to source.feed(now, data) first (a GPS reader)."""
        self._timed = self._timed + ((source, stream),)


    def link(self, name):
        return self.links[name]

    def next_req_id(self):
        self._req_id = (self._req_id + 1) & 0xFFFF
        return self._req_id

    def _on_event(self, ev):
        t = self.transport
        if t is None and ev[0] == _EV_CONTROL:
            return  # route control, and no transport to route
        if t is not None:
            code = ev[0]
            if code == _EV_SEGMENT:
                t.on_segment(self._now, ev[_LINK], ev[_SEG_SRC], ev[_SEG_DST], ev[_SEG_HEAD], ev[_SEG_PAYLOAD], ev[_SEG_AUTHED])
                return
            if code == _EV_CONTROL:
                t.on_control(self._now, ev[_LINK], ev[2], ev[3], ev[4])
                return
            if code == _EV_STATUS and t.on_link_status(self._now, ev[_REQ_ID], ev[_STATUS], ev[_REASON]):
                return
        self.emit(ev)

    def emit(self, ev):
        """Gives ev (acomm.events) to every listener; with none, to the backlog (take_events())."""
        if self.listeners:
            for fn in self.listeners:
                fn(ev)
            return
        if len(self.backlog) >= _EVENT_BACKLOG:
            self.backlog.pop(0)
            self.backlog_dropped += 1
        self.backlog.append(ev)

    def take_events(self):
        ev = self.backlog
        self.backlog = []
        return ev

    def send(self, link_name, dst, data, lifespan_s, priority=10, ack=False, now=None):
        """One frame on one link (priority 1..16, 1 first) -> its request id; exactly one final status follows."""
        rid = self.next_req_id()
        self.links[link_name].request(self.clock() if now is None else now, rid, dst, data, lifespan_s, priority, ack)
        return rid

    def step(self, now=None):
        """One round of work at `now` (default: the clock): transport, links, streams; -> now."""
        if now is None:
            now = self.clock()
        self._now = now
        if self.transport is not None:
            self.transport.poll(now)  # its fragments join the link queues first
        for name in self.links:
            link = self.links[name]
            io = self._io[name]
            stream = io[0]
            pump = io[1]
            if pump is not None:
                pump(now)
                link.poll(now)
                pump(now)
                continue
            if stream is not None:
                # a bounded number of reads: a stream that never runs dry
                # (a babbling device, a fault) must not hold the loop here;
                # what is left is read at the next step
                reads = _READS_PER_STEP
                data = self._read(stream)
                while data:
                    link.feed(now, data)
                    reads -= 1
                    if not reads:
                        break
                    data = self._read(stream)
            link.poll(now)
            if stream is not None:
                self._write(io, link, stream)
        if self._timed:
            self._times(now)
        if self.wallclock is not None:
            self.wallclock.poll(now)
        return now

    def _times(self, now):
        wc = self.wallclock
        for source, stream in self._timed:
            if stream is not None:
                data = self._read(stream)
                if data:
                    source.feed(now, data)
            for ev in source.take_times():
                if wc is not None:
                    wc.fix(ev[_TIME_AT], ev[1], ev[2], ev[3], ev[4])

    def _read(self, stream):
        # A stream whose device went away (pyserial's SerialException is an
        # OSError) must not stop the node: its other links, its transport
        # and its timers go on, and the driver recovers when bytes come back.
        try:
            data = stream.read(_READ_CHUNK)
        except OSError:
            self.stream_errors += 1
            return None
        if data:
            self.moved += 1
        return data

    def _write(self, io, link, stream):
        # machine.UART.write may take only part of the bytes (or return None
        # on timeout): keep the rest (io[2]) and send it first next time,
        # before taking more output from the link.
        out = io[2]
        if not out:
            out = link.take_output()
            if not out:
                return
        try:
            n = stream.write(out)
        except OSError:
            # the bytes are lost as on a cut line (the driver's timeouts
            # see to its commands); not kept, or stale commands would reach
            # the modem when the line comes back
            self.stream_errors += 1
            io[2] = b""
            return
        if not n:
            n = 0
        else:
            self.moved += 1
        io[2] = out[n:] if n < len(out) else b""

    async def run(self, period_ms=10, stop=None):
        # Runs until stop() returns True (forever when stop is None).
        import asyncio

        while stop is None or not stop():
            self.step()
            await asyncio.sleep(period_ms / 1000)

