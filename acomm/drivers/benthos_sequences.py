# The two sequences the Benthos driver (acomm.drivers.benthos) runs on the
# modem's command line: its configuration (BenthosConfig) and the one
# acoustic transaction under way (AcousticSlot); and which line answers which
# of the commands they write (answer).
#
# The configuration, before the driver lets the link transmit, and again
# after the modem restarted or fell silent. The driver first brings the
# modem to command mode (`+++` after the guard time, see benthos.py), then:
#
#   AT                 -> OK: someone is there and in command mode
#   @P1EchoChar=Dis    the recommended goby setup (ref/modem-protocols.md
#   @P1Prompt=7        4.2), each answered by its echo "Name | Value",
#   @Verbose=3         which is checked
#   @DataRetry=Dis
#   @FwdDelay=0.05
#   @LocalAddr=<id>    only when the constructor was given an address
#   @PrintHex=Ena
#   @RcvAll=Ena        (option)
#   @ShowBadData=Ena
#   @OpMode=0
#   @TxRate=<code>
#   @AcRspTmOut=<s>    (option) the reply timeout the driver's watchdog uses
#   ...extra settings given to the constructor
#   @LocalAddr         a query, only when no address was given
#
# goby also sets @WakeTones=Ena (for low power) and the modem clock; the
# driver never sends the modem to low power and has no wall clock, so
# neither is in the default list (add WakeTones with `extra_settings`).
#
# The transaction, from the moment the link hands it over until its end, and
# the events that report it.
#
# A frame:
#   QUEUED   accepted; waits for command mode and a free serial line
#   ADDR     @RemoteAddr=<dst> written (only when it differs from the last
#            one the modem confirmed), waiting for its echo
#   CONNECT  ATO written, waiting for "CONNECT ..."
#   FORWARD  the payload written raw in online mode, waiting for
#            "Forwarding Delay Up" (the modem starts to transmit)
#   AIR      transmitting: EV_TX_DONE at the end of the estimated airtime
#            (the modem does not say); the slot is free once the modem is
#            back at its prompt, or a while later without it (the driver
#            then escapes before the next command)
# A range:
#   QUEUED -> RANGE  ATR<addr> written, waiting for the Range line or
#            "Response Not Received" (EV_RANGE either way)
#
# There is no delivery report on this modem (ref/modem-protocols.md 4.3), so
# a frame ends with EV_TX_DONE alone, or EV_TX_FAILED with a reason.
#
# Which line answers which command: a pure function of the command
# outstanding and the line, so the driver stays about state and time, and the
# matching can be read in one place.
#
#   +++            the prompt (online before: handled by the driver) or
#                  "Command '+++' not found" (command mode already)
#   AT             OK / ERROR
#   @Name=Value    the echo "Name | Value" (the name is checked here, the
#   @Name          value by the caller); "Invalid ...", "Command '...' not
#                  found" or ERROR refuse it
#   ATO            "CONNECT ..." / ERROR / NO CARRIER
#   the payload    "Forwarding Delay Up" (the prompt before it: the driver)
#   ATR<addr>      the Range line for that address / "Response Not
#                  Received" / ERROR; a "TX time ..." line may come first

from ..compat import const, ticks_add, ticks_diff
from ..events import EV_RANGE, EV_TX_DONE, EV_TX_FAILED
from . import benthos_wire as w
from .base import IDLE, QUEUED, ConfigSequence, SlotBase  # noqa: F401 (QUEUED: for the driver)

S_AT = const(0)
S_SET = const(1)
S_QUERY = const(2)


def setup_steps(address, tx_rate, fwd_delay_ms, rcv_all, ac_rsp_tmo_ms, extra, prompt_setting="P1Prompt"):
    # prompt_setting: goby3 at 0bba729 writes @Prompt=7, the reference
    # (goby3 at 2603ff12) @P1Prompt=7
    steps = [(S_AT, "", ""), (S_SET, "P1EchoChar", "Dis"), (S_SET, prompt_setting, "7"), (S_SET, "Verbose", "3")]
    steps.append((S_SET, "DataRetry", "Dis"))
    steps.append((S_SET, "FwdDelay", w.secs_text(fwd_delay_ms)))
    if address is not None:
        steps.append((S_SET, "LocalAddr", str(address)))
    steps.append((S_SET, "PrintHex", "Ena"))
    if rcv_all is not None:
        steps.append((S_SET, "RcvAll", "Ena" if rcv_all else "Dis"))
    steps.append((S_SET, "ShowBadData", "Ena"))
    steps.append((S_SET, "OpMode", "0"))
    steps.append((S_SET, "TxRate", str(tx_rate)))
    if ac_rsp_tmo_ms is not None:
        steps.append((S_SET, "AcRspTmOut", w.secs_text(ac_rsp_tmo_ms)))
    for name, value in extra:
        steps.append((S_SET, name, str(value)))
    if address is None:
        steps.append((S_QUERY, "LocalAddr", ""))
    return steps


class BenthosConfig(ConfigSequence):
    """The modem's configuration: the settings of setup_steps, each checked by its echo."""

    def __init__(self, driver, steps, retry_ms):
        ConfigSequence.__init__(self, driver, retry_ms)
        self.steps = steps
        self.i = 0
        self.mismatch = {}  # settings the modem echoed with another value

    def first(self):
        self.i = 0

    def step(self, now):
        # (pump) the modem is in command mode and no command is outstanding
        kind, name, value = self.steps[self.i]
        d = self.d
        if kind == S_AT:
            d.command_at(now, "AT")
        elif kind == S_SET:
            d.command_set(now, name, value)
        else:
            d.command_query(now, name)

    def reply(self, now, ok, detail):
        # the outcome of the current step's command
        kind, name, value = self.steps[self.i]
        if not ok:
            what = "AT" if kind == S_AT else ("@" + name + ("=" + value if kind == S_SET else ""))
            self.failed(now, "%s: %s" % (what, detail))
            return
        if kind == S_QUERY and name == "LocalAddr":
            a = w.number(detail)
            if a is None or a > w.MAX_ADDR:
                self.failed(now, "LocalAddr is %r" % (detail,))
                return
            self.d.address = a
        elif kind == S_SET and not w.same_value(value, detail):
            if w.milli(value) is not None:
                # a number the modem did not take (an address, a rate)
                self.failed(now, "%s is %s, not %s" % (name, detail, value))
                return
            self.mismatch[name] = detail
        self.i += 1
        if self.i >= len(self.steps):
            self.done(now)

    def failed(self, now, reason):
        # start over from the escape: the modem may have gone back online
        ConfigSequence.failed(self, now, reason)
        self.d.resync()


ADDR = const(2)
CONNECT = const(3)
FORWARD = const(4)
AIR = const(5)
RANGE = const(6)

K_DATA = const(0)
K_PING = const(1)


class AcousticSlot(SlotBase):
    """The one frame or range in flight."""

    def __init__(self, driver, cap):
        SlotBase.__init__(self, driver, cap)
        self.free_at = None  # give up waiting for the prompt

    def accept(self, handle, kind, addr, data):
        self._take(handle, kind, addr, data)
        self.free_at = None

    def start(self, now):
        # the modem is in command mode and the serial line is free
        d = self.d
        if self.kind == K_PING:
            self.state = RANGE
            d.command_range(now, self.addr)
        elif d.remote != self.addr:
            self.state = ADDR
            d.command_set(now, "RemoteAddr", str(self.addr))
        else:
            self.state = CONNECT
            d.command_ato(now)

    def reply(self, now, ok, detail):
        # the outcome of the command this slot wrote
        d = self.d
        st = self.state
        if st == ADDR:
            if not ok:
                d.remote = None
                self.fail("@RemoteAddr=%d: %s" % (self.addr, detail))
                return
            d.remote = self.addr
            self.state = CONNECT
            d.command_ato(now)
        elif st == CONNECT:
            if not ok:
                self.fail("ATO: %s" % detail)
                return
            self.state = FORWARD
            d.command_payload(now, memoryview(self.buf)[: self.n])
        elif st == FORWARD:
            if not ok:
                # it may be on the air all the same: the next transaction
                # waits until it would be over
                d.hold(ticks_add(now, self.airtime()))
                self.fail(detail)
                return
            self.state = AIR
            self.done_at = ticks_add(now, self.airtime())
            self.free_at = ticks_add(self.done_at, d.prompt_timeout_ms)
        elif st == RANGE:
            if ok:
                src, dst, metres, rt, speed = detail
                extra = {"round_trip_ms": rt, "speed": speed, "from": src}
                self.state = IDLE
                d._events.append((EV_RANGE, self.handle, dst, metres, extra))
            elif detail == w.NO_RESPONSE:
                self.state = IDLE
                d._events.append((EV_RANGE, self.handle, None, None, {"reply": detail}))
            else:
                self.fail("ATR%d: %s" % (self.addr, detail))

    def airtime(self):
        return self.d.airtime_ms(self.n)

    def poll(self, now, in_command_mode):
        if self.state != AIR:
            return
        if self.done_at is not None and ticks_diff(now, self.done_at) >= 0:
            self.done_at = None
            self.d._events.append((EV_TX_DONE, self.handle))
        if self.done_at is None and (in_command_mode or ticks_diff(now, self.free_at) >= 0):
            self.state = IDLE

    def fail(self, reason):
        self.state = IDLE
        self.d._events.append((EV_TX_FAILED, self.handle, reason))

    def lost(self, reason):
        # the modem restarted or stopped answering
        if self.state == AIR and self.done_at is None:
            self.state = IDLE  # already reported as sent
        elif self.state != IDLE:
            self.fail(reason)


# -- answers ------------------------------------------------------------------
C_ESCAPE = const(1)
C_AT = const(2)
C_SET = const(3)
C_QUERY = const(4)
C_ATO = const(5)
C_PAYLOAD = const(6)
C_RANGE = const(7)

INFO = (None, None)  # a line that belongs to the command without ending it


def answer(kind, name, addr, s):
    # -> (ok, detail) when s ends the command, INFO, or None when s does not
    # answer it. name: the setting of C_SET / C_QUERY; addr: the address
    # of C_RANGE.
    if kind == C_ESCAPE:
        if s == w.NOT_FOUND:
            return True, ""
    elif kind == C_AT:
        if s == "OK" or s == "ERROR":
            return s == "OK", s
    elif kind == C_SET or kind == C_QUERY:
        e = w.parse_echo(s)
        if e is not None and e[0].lower() == name.lower():
            return True, e[1]
        if s == "ERROR" or s.startswith("Invalid") or (s.startswith("Command '") and s != w.NOT_FOUND):
            return False, s
    elif kind == C_ATO:
        if s.startswith("CONNECT"):
            return True, s
        if s == "ERROR" or s == "NO CARRIER":
            return False, s
    elif kind == C_PAYLOAD:
        if s.startswith(w.FWD_UP):
            return True, s
    elif kind == C_RANGE:
        if s[:7].lower() == "tx time":
            return INFO
        r = w.parse_range(s)
        if r is not None and r[1] == addr:
            return True, r
        if s == w.NO_RESPONSE or s == "ERROR":
            return False, s
    return None


def stray(s):
    # an answer of the modem's that comes when nothing is asked (late, or
    # after a command the driver gave up on): known, so not counted as junk
    return s == "OK" or s == w.NOT_FOUND or s.startswith("CONNECT") or s.startswith(w.FWD_UP)
