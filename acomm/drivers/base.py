"""The driver interface and what the drivers share.

Every driver is sans-IO: bytes and time (integer milliseconds) in, bytes
and events (acomm.events EV_*) out; it never sleeps and does no I/O. The
interface a driver offers to acomm.link.Link:

  caps                  acomm.drivers.caps.Capabilities
  broadcast_addr        the interface address meaning "everyone"
  ready(now)            True when send() or ping() would be accepted now
  send(now, addr, data, ack=False) -> handle
                        start transmitting one frame (ack: ask for a
                        delivery report where the modem gives one); raises
                        an acomm error when it cannot take it (EncodeError
                        for a bad size or address; the link asks ready()
                        first). What becomes of it comes later as events
                        for the handle (EV_TX_DONE, EV_DELIVERED,
                        EV_TX_FAILED; docs/drivers*.md say which)
  ping(now, addr) -> handle
                        ranging drivers only; never raises: a refused ping
                        is an EV_TX_FAILED for its handle; otherwise it ends
                        in one EV_RANGE (metres None when nobody answered)
                        or EV_TX_FAILED
  feed(now, data)       bytes read from the device, split anywhere; bad
                        input is counted, never raised
  poll(now)             let timers run (deadlines, probes, retries)
  take_events() -> list events since the last call
  take_output() -> bytes
                        bytes to write to the device (b"" when none)
"""

# What follows, from the most general:
#
# SansIO (every driver, and the emulators in ports/sim): the event list and
# the output buffer that the owner drains.
#
# SlotDriver (the acoustic drivers and the AT family): the driver's life
# (configuring, up, and down again when the modem restarts or falls silent),
# the handles the link gets for its requests, a request refused through the
# event list, and the slot that holds the one transaction under way.
#
# AcousticDriver (SeaTrac, EvoLogics, Micro-Modem, Benthos) adds the command
# slot: one command on the serial line awaiting its answer, with a deadline.
# An unanswered command outside the configuration counts as silence; after
# down_after of them in a row the modem is lost (set up again), before that
# the driver probes it. A hold keeps the next acoustic command back while
# the modem may still be busy.
#
# ConfigSequence: the steps a driver walks before the modem is up, with the
# one retry rule: a failed step starts the sequence over after retry_ms,
# and the link hears EV_DRIVER_DOWN once per outage, after down_after
# failures in a row.
#
# SlotBase: the one transaction itself; each modem's slot adds its own
# states (after QUEUED) and how the transaction goes on its wire.
#
# SyncLines: cutting a serial byte stream into lines that start with a sync
# character and end in CR, LF or both, what the SeaTrac reader ('#' / '$'
# hex lines, seatrac_wire) and the Micro-Modem reader ('$' NMEA sentences,
# micromodem_wire) share. Only the bounds of a line are found here; the
# subclass checks and decodes a whole one in _end_line(n), with the bytes
# between sync and line end in self._line[:n]. Framing trouble is counted in
# self.junk and reported to sink.on_junk(kind): characters outside any line
# (noise, boot text), a line cut short by the next sync, and a line longer
# than the buffer. Each protocol names these kinds its own way (ints in one,
# strings in the other: they are the keys callers read in junk), so the
# subclass passes its names in. One preallocated buffer; nothing is
# allocated per byte.
#
# They share one module because a board pays for every module it loads.

from ..compat import const, ticks_add, ticks_diff

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DRIVER_DOWN = const(7)
_EV_DRIVER_UP = const(6)
_EV_TX_FAILED = const(4)

# the driver's own state
S_START = const(0)  # created: the first poll() starts the configuration
S_CONFIG = const(1)  # (re)configuring; also "down" while the modem is silent
S_UP = const(2)

# the two states every slot has; each modem's slot numbers its own from 2
IDLE = const(0)
QUEUED = const(1)


class SansIO:
    """An event list and an output buffer, drained by the owner."""

    def __init__(self):
        self._events = []
        self._out = bytearray()

    def take_events(self):
        """The events since the last call (an empty list when there are none)."""
        ev = self._events
        if not ev:
            return ev
        self._events = []
        return ev

    def take_output(self):
        """The bytes to write to the device since the last call (b"" when there are none)."""
        if not self._out:
            return b""
        out = bytes(self._out)
        self._out = bytearray()
        return out


class SlotDriver(SansIO):
    """A driver with one request slot (self.slot) and a configuration (self.config).

    The subclass provides self.config (start(now), down_reported), self.slot
    (state, and accept() for _accept) and self._pump(now), which writes the
    next command when it can.
    """

    def __init__(self):
        SansIO.__init__(self)
        self._state = S_START
        self._h = 0  # the last handle given out

    def ready(self, now):
        """True when send() or ping() would be accepted now."""
        return self._state == S_UP and self.slot.state == IDLE

    def _begin(self, now):
        # for poll(): the first one starts the configuration
        if self._state == S_START:
            self._state = S_CONFIG
            self.config.start(now)

    def configured(self, now):
        """Called when the configuration's last step is done: the driver is up."""
        self._silent = 0
        self._state = S_UP
        self._events.append((_EV_DRIVER_UP,))

    def _went_down(self, reason):
        # Only a driver that was up says so here; a configuration that keeps
        # failing says it through _say_down.
        if self._state == S_UP:
            self._say_down(reason)

    def _say_down(self, reason):
        # EV_DRIVER_DOWN once per outage: the configuration's flag is set
        # until the modem is up again
        c = self.config
        if not c.down_reported:
            c.down_reported = True
            self._events.append((_EV_DRIVER_DOWN, reason))

    def _handle(self):
        self._h = (self._h + 1) & 0xFFFF
        return self._h

    def _refuse(self, reason):
        # ping() never raises (the link calls it without a guard): a problem
        # comes back as EV_TX_FAILED for a handle of its own
        h = self._handle()
        self._events.append((_EV_TX_FAILED, h, reason))
        return h

    def _accept(self, now, kind, addr, *rest):
        # the slot takes the request (rest: what that modem's slot needs
        # besides kind and address), and the command goes out as soon as
        # the serial line is free
        h = self._handle()
        self.slot.accept(h, kind, addr, *rest)
        self._pump(now)
        return h


class AcousticDriver(SlotDriver):
    """A SlotDriver with the command slot: one serial command at a time.

    The subclass sets down_after, alive_period_ms, stats (with
    "cmd_timeouts") and _reader (a LineReader), and provides
    _next_command(now) (the command to write once up, if any),
    _unanswered(now, what) (what an unanswered command meant; in the
    configuration: self.config.failed) and _slot_gave_up(now).
    """

    probe_gap_ms = 0  # the least time between two probes

    def __init__(self):
        SlotDriver.__init__(self)
        self._now = 0
        self.cmd = 0  # what the command slot waits for, 0 for nothing (read it; the driver sets it)
        self._cmd_deadline = 0
        self._silent = 0  # commands unanswered in a row
        self._heard = None  # when the modem last said something valid
        self._hold_until = None  # no acoustic command before this
        self._probe = False  # a probe is due
        self._probe_after = None

    def _await(self, now, what, timeout_ms):
        # the command just written occupies the slot until its answer
        self.cmd = what
        self._cmd_deadline = ticks_add(now, timeout_ms)

    def _heard_from(self, now):
        # the modem answered: it is alive
        self._heard = now
        self._silent = 0

    def _pump(self, now):
        # Writes the next command when the slot is free: the configuration's
        # while configuring, once up the driver's own (_next_command).
        if self.cmd:
            return
        if self._state == S_UP:
            self._next_command(now)
        elif self._state == S_CONFIG:
            self.config.pump(now)

    def feed(self, now, data):
        """Bytes read from the device (the driver's LineReader cuts them up)."""
        self._now = now
        self._reader.feed(data)
        self._pump(now)

    def poll(self, now):
        """Let timers run: the command's and the transaction's deadlines, probes, retries."""
        self._now = now
        self._begin(now)
        if self.cmd and ticks_diff(now, self._cmd_deadline) >= 0:
            self._cmd_timed_out(now)
        if self.slot.poll(now):
            self._slot_gave_up(now)  # its watchdog found the modem silent
        self._pump(now)

    def _cmd_timed_out(self, now):
        what = self.cmd
        self.cmd = 0
        self.stats["cmd_timeouts"] += 1
        self._silent += 1
        self._unanswered(now, what)
        if self._state == S_UP:  # the configuration counts its own failures
            if self._silent >= self.down_after:
                self.lost(now, "modem not answering")
            else:
                self._probe = True

    def _held(self, now):
        # True while an acoustic command must wait (the modem may still be
        # busy with the last one); the hold ends once its time has come
        h = self._hold_until
        if h is None:
            return False
        if ticks_diff(now, h) < 0:
            return True
        self._hold_until = None
        return False

    def _probe_due(self, now):
        # True when the modem should be asked whether it is still there: a
        # probe was asked for (no closer than probe_gap_ms to the last), or
        # it has said nothing for alive_period_ms
        due = self._probe and (self._probe_after is None or ticks_diff(now, self._probe_after) >= 0)
        if not due and self.alive_period_ms and self._heard is not None:
            due = ticks_diff(now, self._heard) >= self.alive_period_ms
        if due:
            self._probe = False
            self._probe_after = ticks_add(now, self.probe_gap_ms)
        return due

    def _set_up_again(self, now, wait_ms=0):
        # whatever the command slot held is gone: configure the modem again
        self.cmd = 0
        self._silent = 0
        self._hold_until = None
        self._probe = False
        self._state = S_CONFIG
        self.config.start(now, wait_ms)


class ConfigSequence:
    """The configuration steps of one modem, with the shared retry rule.

    The subclass provides first() (back to step one) and step(now) (write the
    current step's command through the driver), and calls failed(now, reason)
    or done(now). problem holds the reason of the last failure.
    """

    def __init__(self, driver, retry_ms):
        self.d = driver  # the AcousticDriver: command writer and event list
        self.retry_ms = retry_ms
        self.fails = 0  # failed rounds in a row
        self.down_reported = False
        self.problem = None
        self._wait = None  # no step before this

    def start(self, now, wait_ms=0):
        """Start over from the first step, after wait_ms."""
        self._wait = ticks_add(now, wait_ms) if wait_ms else None
        self.first()

    def pump(self, now):
        """Write the current step, if its time has come (the command slot is free)."""
        if self._wait is not None:
            if ticks_diff(now, self._wait) < 0:
                return
            self._wait = None
        self.step(now)

    def failed(self, now, reason):
        """A step failed: start over after retry_ms; down_after failures in a row say the modem is down."""
        self.fails += 1
        self.problem = reason
        d = self.d
        if self.fails >= d.down_after:
            d._say_down(reason)
        self.start(now, self.retry_ms)

    def done(self, now):
        """The last step succeeded: the driver is up."""
        self.fails = 0
        self.down_reported = False
        self.problem = None
        self.d.configured(now)


class SlotBase:
    """The one transaction: what the link asked for and the copy of its bytes."""

    def __init__(self, driver, capacity):
        self.d = driver  # timing model, settings and the event list
        self.state = IDLE
        self.kind = 0
        self.handle = 0
        self.addr = 0
        self.n = 0
        self.buf = bytearray(capacity)
        self.done_at = None  # when our packet has left: EV_TX_DONE

    def _take(self, handle, kind, addr, data):
        # A copy of the bytes (the link may reuse its buffer), queued until
        # the driver can write the command.
        n = len(data)
        self.buf[:n] = data
        self.n = n
        self.kind = kind
        self.handle = handle
        self.addr = addr
        self.done_at = None
        self.state = QUEUED


class SyncLines:
    """The bounds of sync-to-CR/LF lines in a byte stream; the subclass decodes each whole line.

    The subclass names its junk kinds as class attributes: _k_text (bytes
    outside any line), _k_cut (a line cut by the next sync), _k_long (longer
    than the buffer). Class attributes, not per instance: on MicroPython
    three fewer attributes keep a reader's table a step (56 bytes) smaller.
    """

    def __init__(self, sync, sink, cap):
        self.sync = sync
        self._sink = sink
        self._line = bytearray(cap)
        self.junk = {}
        self.reset()

    def reset(self):
        self._n = 0
        self._in = False
        self._over = False
        self._text = 0  # characters seen outside any line

    def _junk(self, kind):
        self.junk[kind] = self.junk.get(kind, 0) + 1
        self._sink.on_junk(kind)

    def feed(self, data):
        sync = self.sync
        line = self._line
        cap = len(line)
        n = self._n
        for b in data:
            if b == sync:
                if self._in:
                    self._n = n
                    self._junk(self._k_cut)
                elif self._text:
                    self._junk(self._k_text)
                self._in = True
                self._over = False
                self._text = 0
                n = 0
            elif b == 13 or b == 10:
                if self._in:
                    self._in = False
                    self._n = n
                    if self._over:
                        self._over = False
                        self._junk(self._k_long)
                    else:
                        self._end_line(n)
                    n = 0
                elif self._text:
                    self._text = 0
                    self._junk(self._k_text)
            elif self._in:
                if n < cap:
                    line[n] = b
                    n += 1
                else:
                    self._over = True
            else:
                self._text += 1
        self._n = n
