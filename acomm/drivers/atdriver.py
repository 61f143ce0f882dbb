# The life of a driver for a Hayes-AT surface modem (Iridium SBD, GSM SMS),
# shared by both: the start-up sequence, "up" and "down" (a modem that stops
# answering, restarts, or has no signal), the periodic signal poll that also
# serves as keepalive, and the one-request slot (acomm.drivers.base).
# The subclass gives the command list, the work it does when the modem is
# up (_work), what its commands' answers mean (_result, _info, _prompt,
# _block), its URCs (_urc), its timers (_tick), how it reads the signal
# (parse_signal, raising DecodeError, and _signal_ok) and what a restart
# does to its request (_lost).
#
# Start-up: each step is (command, wanted info prefix or None, timeout or
# None). A step that fails (ERROR, timeout, missing info) starts the list
# again after retry_ms; the driver says it is down once after down_after
# failed rounds. The first step, "ATE0Q0V1", puts a unit left in any mode
# (echo on, numeric results, quiet) into ours, and takes a numeric "0" as
# its OK (a unit in ATV0 answers so); it turns the echo off. After it has been answered an echo of our own command
# means the modem restarted and lost its settings; so do banner lines.
# down_after commands in a row without an answer make it restart too.
#
# Signal: the subclass turns the +CSQ answer into "usable or not". Without
# signal ready() is false (the link keeps its frames, ordered, in its own
# queue), caps.bitrate is 0 (so the transport's router prefers other links),
# and the driver says EV_DRIVER_DOWN "no signal" once; EV_DRIVER_UP when it
# comes back.
#
# Time: a subclass that can ask the modem for the time sets time_spec =
# (command, source name, uncertainty in ms) (Iridium b"AT-MSSTM", GSM
# b"AT+CCLK?"), time_period_ms, and parse_time(line) -> (secs, ms) or None
# (no time yet). The driver asks when the line is free and it has nothing
# else to do: at once when it is up, then every time_period_ms (and when the
# subclass sets _time_at = now, after an Iridium session); a "no time"
# answer asks again after csq_period_ms. The last time read is a tuple
# (EV_TIME, source, secs, ms, unc_ms, now) that take_times() hands to the
# node's wall clock (acomm.wallclock).

from ..compat import const, ticks_add, ticks_diff
from ..errors import DecodeError
from .atcommand import AtChannel
from .base import SlotBase, SlotDriver

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_R_OK = const(0)  # acomm.drivers.atcommand
_R_TIMEOUT = const(3)  # acomm.drivers.atcommand
_S_CONFIG = const(1)  # acomm.drivers.base
_S_START = const(0)  # acomm.drivers.base
_S_UP = const(2)  # acomm.drivers.base

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DRIVER_DOWN = const(7)
_EV_DRIVER_UP = const(6)
_EV_TIME = const(9)

_T_CONFIG = const(1)
_T_CSQ = const(2)
_T_TIME = const(3)
# the subclasses number their own command tags from 10


class AtSlot(SlotBase):
    # the one request: a copy of its bytes until the modem has it
    def accept(self, handle, kind, addr, data):
        self._take(handle, kind, addr, data)


class AtDriver(SlotDriver):
    # the time: off unless a subclass asks (class attributes, so that a
    # driver without it takes no slot for them on a board)
    time_spec = None  # (command, source, uncertainty_ms)
    time_period_ms = 0
    _time_at = None  # when to ask next; None: as soon as the driver is up
    _fix = None  # the last time read, until take_times()

    def __init__(self, steps, urcs, mtu, line_cap, block_cap, cmd_timeout_ms, retry_ms, down_after,
                 csq_period_ms, csq_retry_ms, csq_timeout_ms, banner_marks):
        SlotDriver.__init__(self)
        self.steps = steps
        self.cmd_timeout_ms = cmd_timeout_ms
        self.retry_ms = retry_ms
        self.down_after = down_after
        self.csq_period_ms = csq_period_ms
        self.csq_retry_ms = csq_retry_ms
        self.csq_timeout_ms = csq_timeout_ms
        self.banner_marks = banner_marks
        self.at = AtChannel(self, urcs, line_cap, block_cap)
        self.config = self  # SlotDriver's start(now) / down_reported
        self.slot = AtSlot(self, mtu)
        self.down_reported = False
        self.signal = None  # the last +CSQ value, on the modem's scale
        self.signal_ok = False
        self.problem = None  # why the last start-up round failed
        self.stats = {"reboots": 0, "unexpected": 0, "refused": 0}
        self._bitrate = 0  # caps.bitrate while there is signal
        self._step = 0
        self._step_seen = False
        self._wait = None
        self._fails = 0
        self._silent = 0
        self._echo_off = False
        self._csq_at = None
        self._signal_said = None  # what the link was last told (True up)
        self._now = 0

    @property
    def junk(self):
        return self.at.junk

    def ready(self, now):
        return SlotDriver.ready(self, now) and self.signal_ok

    # -- the driver interface ------------------------------------------------------
    def feed(self, now, data):
        self._now = now
        self.at.feed(data)
        self._pump(now)

    def poll(self, now):
        self._now = now
        self._begin(now)
        self.at.poll(now)
        self._tick(now)
        self._pump(now)

    def _pump(self, now):
        # the next command, once the line is free
        at = self.at
        if self._state == _S_START or at.busy(now):
            return
        if self._state == _S_CONFIG:
            if self._wait is not None:
                if ticks_diff(now, self._wait) < 0:
                    return
                self._wait = None
            text, _, tmo = self.steps[self._step]
            self._step_seen = False
            at.command(now, text, _T_CONFIG, tmo or self.cmd_timeout_ms, numeric=not self._echo_off)
            return
        if self._work(now):
            return
        if self.time_period_ms and (self._time_at is None or ticks_diff(now, self._time_at) >= 0):
            self._time_at = ticks_add(now, self.time_period_ms)
            at.command(now, self.time_spec[0], _T_TIME, self.cmd_timeout_ms)
            return
        if self._csq_at is None or ticks_diff(now, self._csq_at) >= 0:
            self.poll_signal(now)

    def _tick(self, now):
        pass

    def stuck_reason(self):
        # why a request is still waiting for the modem
        if self._state != _S_UP:
            return "modem not answering"
        if not self.signal_ok:
            return "no signal"
        return None

    def poll_signal(self, now):
        self._csq_at = ticks_add(now, self.csq_period_ms if self.signal_ok else self.csq_retry_ms)
        self.at.command(now, b"AT+CSQ", _T_CSQ, self.csq_timeout_ms)

    def take_times(self):
        """The time read since the last call, if any: a tuple of (EV_TIME, source, secs, ms, unc_ms, at)."""
        f = self._fix
        if f is None:
            return ()
        self._fix = None
        return (f,)

    def _time(self, line):
        try:
            t = self.parse_time(line)
        except DecodeError:
            self.stats["unexpected"] += 1
            return
        now = self._now
        if t is None:
            # no network time yet: ask again at the signal's pace
            self._time_at = ticks_add(now, self.csq_period_ms)
            return
        spec = self.time_spec
        self._fix = (_EV_TIME, spec[1], t[0], t[1], spec[2], now)

    def signal_soon(self, now):
        # read the signal before the next session (after a failed one)
        self._csq_at = now

    # -- the start-up sequence -----------------------------------------------------
    def start(self, now):
        self._step = 0
        self._wait = None
        self._echo_off = False

    def _config_result(self, now, code, line):
        text, want, _ = self.steps[self._step]
        if code != _R_OK or (want is not None and not self._step_seen):
            what = "no reply" if code == _R_TIMEOUT else (line.decode() if code != _R_OK else "no %s" % want.decode())
            self._config_failed(now, "%s: %s" % (text.decode(), what))
            return
        if text.startswith(b"ATE0"):
            self._echo_off = True
        self._step += 1
        if self._step >= len(self.steps):
            self._fails = 0
            self.problem = None
            self.down_reported = False
            self.configured(now)
            self._signal_said = True
            self._csq_at = ticks_add(now, self.csq_period_ms)
            self._say_signal(now)

    def _config_failed(self, now, reason):
        self.problem = reason
        self._fails += 1
        if self._fails >= self.down_after:
            self._say_down(reason)
        self._step = 0
        self._wait = ticks_add(now, self.retry_ms)

    # -- the signal ----------------------------------------------------------------
    def set_signal(self, now, value):
        self.signal = value
        ok = self._signal_ok(value)
        if ok != self.signal_ok:
            self.signal_ok = ok
            self.caps.bitrate = self._bitrate if ok else 0
            if self._state == _S_UP:
                self._say_signal(now)

    def _say_signal(self, now):
        ok = self.signal_ok
        if self._signal_said != ok:
            self._signal_said = ok
            self._events.append((_EV_DRIVER_UP,) if ok else (_EV_DRIVER_DOWN, "no signal"))
        if not ok:
            self._csq_at = ticks_add(now, self.csq_retry_ms)

    # -- answers from the AT channel (its sink) ----------------------------------------
    def on_result(self, tag, code, line):
        now = self._now
        if code == _R_TIMEOUT:
            self._silent += 1
        else:
            self._silent = 0
        if tag == _T_CONFIG:
            self._config_result(now, code, line)
            return
        if tag != _T_CSQ and tag != _T_TIME:
            # (a modem without the time command answers ERROR: asked
            # again only after time_period_ms)
            self._result(now, tag, code, line)
        if self._silent >= self.down_after and self._state == _S_UP:
            self.lost(now, "modem not answering")

    def on_info(self, tag, line):
        if self._banner(line):
            return
        if line.startswith(b"+CSQ"):
            try:
                v = self.parse_signal(line)
            except DecodeError:
                self.stats["unexpected"] += 1
                return
            self.set_signal(self._now, v)
            self._step_seen = True
            return
        if tag == _T_CONFIG:
            want = self.steps[self._step][1]
            if want is not None and line.startswith(want):
                self._step_seen = True
            return
        if tag == _T_TIME:
            self._time(line)
            return
        if not self._info(tag, line):
            self.stats["unexpected"] += 1

    def on_prompt(self, tag):
        self._prompt(self._now, tag)

    def on_block(self, tag, buf, n):
        self._block(self._now, tag, buf, n)

    def on_urc(self, line):
        # an unsolicited line, even in the middle of a command: never its
        # answer, except where it is what the start-up step asks for (the
        # SMS driver's "+CPIN: READY" to AT+CPIN?); a banner mark is a restart
        if self._banner(line):
            return
        if self.at.tag == _T_CONFIG:
            want = self.steps[self._step][1]
            if want is not None and line.startswith(want):
                self._step_seen = True
                return
        if self._state == _S_UP:
            self._urc(self._now, line)

    def on_echo(self):
        if self._echo_off:
            # ATE0 was answered: a modem that echoes again has restarted
            self.stats["reboots"] += 1
            self.lost(self._now, "modem restarted (its echo is back)")

    def on_stray(self, line):
        if not self._banner(line):
            self.stats["unexpected"] += 1

    def _banner(self, line):
        # a power-up line, even in the middle of a command: the modem
        # restarted (True)
        for m in self.banner_marks:
            if line.startswith(m):
                self.stats["reboots"] += 1
                if self._state != _S_START:
                    self.lost(self._now, "modem rebooted")
                return True
        return False

    # -- restarts ------------------------------------------------------------------------
    def lost(self, now, reason):
        # The modem restarted or fell silent: configure it again; the
        # subclass decides what becomes of its request.
        self._went_down(reason)
        self.at.reset()
        self._silent = 0
        self._state = _S_CONFIG
        if self.time_period_ms:
            self._time_at = None  # the time again once it is back
        self.start(now)
        self._lost(now, reason)

