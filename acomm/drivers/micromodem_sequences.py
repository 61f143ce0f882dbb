# The two sequences the Micro-Modem driver (acomm.drivers.micromodem) runs:
# its configuration (MicroModemConfig) and the one acoustic transaction under
# way (AcousticSlot).
#
# The configuration, before the driver lets the link send, and again after
# the modem rebooted ($CAREV,...,INIT) or stopped answering:
#
#   $CCCFG,SRC,<address>      when the constructor was given an address
#                             (NVRAM SRC; the modem echoes $CACFG,SRC,<address>)
#   $CCCFQ,SRC                when asked to (by default: only when no address
#                             was given): $CACFG,SRC,<n> tells the driver the
#                             modem's own address
#   $CCCLK,YYYY,MM,DD,HH,MM,SS  when a clock function was given (MM1 sentence;
#                             the modem echoes $CACLK)
#
# Each sentence goes through the driver's command slot, which resends it
# after modem_wait_ms up to `retries` times (goby3: 5 s, 3 times). When one
# stays unanswered the sequence starts over after retry_ms, and the link is
# told once (EV_DRIVER_DOWN) per outage: after the first such failure, since
# the resends already waited (the driver's down_after is 1).
#
# The transaction, from the moment the link hands it over until the modem's
# final word on it (or the driver's watchdog), and the events that tell the
# link:
#
# data frame (K_DATA), one frame per cycle:
#   CYC   $CCCYC written; waiting for $CACYC (resent if unanswered)
#   DRQ   $CACYC seen; waiting for the modem's $CADRQ (at rate 0 the
#         cycle-init mini-packet's $CATXP / $CATXF come first)
#   TXD   $CCTXD written in answer; waiting for $CATXD
#   AIR   the modem took the frame: $CATXF ends it (EV_TX_DONE); then,
#         acknowledged sends only,
#   ACK   waiting for $CAACK (EV_DELIVERED) until the round trip at the
#         maximum range has passed (EV_TX_FAILED "no acknowledgement")
# mini-packet (K_MINI): MUC ($CCMUC written, waiting for $CAMUC), then AIR
# ping (K_PING): MPC ($CCMPC written, waiting for $CAMPC), then RANGE
#   (waiting for $CAMPR: EV_RANGE with metres, or with None on a timeout)

from ..compat import const, ticks_add, ticks_diff
from ..events import EV_DELIVERED, EV_RANGE, EV_TX_DONE, EV_TX_FAILED
from . import micromodem_wire as w
from .base import ConfigSequence


class MicroModemConfig(ConfigSequence):
    """The modem's configuration: its address (set or asked) and its clock."""

    def __init__(self, driver, address, query_src, clock, retry_ms):
        ConfigSequence.__init__(self, driver, retry_ms)
        self.want = address
        self.query_src = (address is None) if query_src is None else query_src
        self.clock = clock
        self._steps = []
        self._i = 0

    def first(self):
        steps = []
        if self.want is not None:
            steps.append(("CCCFG", ("SRC", self.want), b"CACFG"))
        if self.query_src:
            steps.append(("CCCFQ", ("SRC",), b"CACFG"))
        if self.clock is not None:
            steps.append(("CCCLK", None, b"CACLK"))
        self._steps = steps
        self._i = 0

    def step(self, now):
        if self._i >= len(self._steps):
            self.done(now)
            return
        name, args, expect = self._steps[self._i]
        if args is None:  # the clock, read at the moment it is sent
            args = tuple(self.clock())
        self.d.command(now, w.sentence(name, *args), expect)

    def answer(self, now, f):
        # The reply to the step in progress (f: the sentence's fields).
        # Returns False when it is not (someone else's $CACFG, say).
        name, args, expect = self._steps[self._i]
        if f[0] != expect:
            return False
        if expect == b"CACFG":
            if len(f) < 3 or f[1] != b"SRC":
                return False
            addr = w.num(f[2], 0, 254)
            if addr is None:
                self.failed(now, "modem reports SRC %r" % (bytes(f[2]),))
                return True
            if name == "CCCFG" and addr != self.want:
                return False  # not the echo of our setting
            self.d.own_addr = addr
        self._i += 1
        return True


IDLE = const(0)
CYC = const(1)
DRQ = const(2)
TXD = const(3)
AIR = const(4)
ACK = const(5)
MUC = const(6)
MPC = const(7)
RANGE = const(8)

K_DATA = const(0)
K_MINI = const(1)
K_PING = const(2)

# the echo that answers the sentence each waiting state wrote
ECHO = {CYC: b"CACYC", MUC: b"CAMUC", MPC: b"CAMPC"}


class AcousticSlot:
    def __init__(self, driver):
        self.d = driver
        self.state = IDLE
        self.kind = K_DATA
        self.handle = 0
        self.addr = 0
        self.ack = False
        self.data = b""
        self.mini = 0
        self.deadline = None
        self.tx_done_sent = False

    def busy(self):
        return self.state != IDLE

    # -- starting ------------------------------------------------------------
    def start(self, now, handle, kind, addr, data=b"", ack=False, mini=0):
        self.handle = handle
        self.kind = kind
        self.addr = addr
        self.data = data
        self.ack = ack
        self.mini = mini
        self.tx_done_sent = False
        d = self.d
        src = d.own_addr if d.own_addr is not None else 0
        if kind == K_DATA:
            self.state = CYC
            # CMD 0 (deprecated), SRC, DEST, RATE, ACK, NFRAMES = 1
            d.command(now, w.sentence("CCCYC", 0, src, addr, d.rate, 1 if ack else 0, 1), b"CACYC")
        elif kind == K_MINI:
            self.state = MUC
            d.command(now, w.sentence("CCMUC", src, addr, "%04X" % mini), b"CAMUC")
        else:
            self.state = MPC
            d.command(now, w.sentence("CCMPC", src, addr), b"CAMPC")

    # -- answers from the modem ------------------------------------------------
    def echoed(self, now, name):
        # The echo of the sentence we wrote (the driver matched the name).
        d = self.d
        if self.state == CYC:
            self.state = DRQ
            self.deadline = ticks_add(now, d.modem_wait_ms)
        elif self.state == MUC:
            self._on_air(now, d.air.mini_ms())
        elif self.state == MPC:
            self.state = RANGE
            self.deadline = ticks_add(now, d.ping_window_ms())

    def data_request(self, now, dst, nbytes):
        # $CADRQ for our cycle (also when its $CACYC got lost).
        d = self.d
        if self.kind != K_DATA or self.state not in (CYC, DRQ) or dst != self.addr:
            return False
        d.cancel_command()
        src = d.own_addr if d.own_addr is not None else 0
        flag = 1 if self.ack else 0
        if nbytes is not None and len(self.data) > nbytes:
            # the modem runs another rate than configured: close the cycle
            d.write(w.sentence("CCTXD", src, self.addr, flag, ""))
            self.fail("modem asked for %d bytes, frame has %d" % (nbytes, len(self.data)))
            return True
        d.write(w.sentence("CCTXD", src, self.addr, flag, w.hexlify(self.data)))
        self.state = TXD
        self.deadline = ticks_add(now, d.modem_wait_ms)
        return True

    def transmitting(self, now, name):
        # $CATXD (echo of our data), $CATXP (start) or $CATXF (end); the
        # first of them that arrives puts the transaction on the air (the
        # ones before it may have been lost).
        st = self.state
        if (st == CYC or st == DRQ) and self.kind == K_DATA:
            # rate 0: the cycle-init mini-packet leaves before the modem
            # asks for data; its $CATXF says the $CADRQ is near (and that
            # the $CACYC came, should it have been lost)
            d = self.d
            d.cancel_command()
            self.state = DRQ
            self.deadline = ticks_add(now, d.air.mini_ms() + d.modem_wait_ms)
            return True
        if st == TXD or st == MUC:
            d = self.d
            d.cancel_command()
            self._on_air(now, d.air.mini_ms() if st == MUC else d.air.packet_ms(d.rate, len(self.data)))
        elif st != AIR:
            return False
        if name == b"CATXF":
            self._tx_done(now)
        return True

    def acked(self, now, a, b, frame):
        # $CAACK: the remote's acknowledgement of our frame.
        if self.kind != K_DATA or not self.ack or self.state not in (TXD, AIR, ACK):
            return False
        if self.addr not in (a, b) or frame != 1:
            return False
        self._tx_done(now)  # the end-of-transmission line may have been lost
        self.state = IDLE
        self.deadline = None
        self.d._events.append((EV_DELIVERED, self.handle))
        return True

    def ranged(self, now, remote, travel_s):
        if self.kind != K_PING or self.state not in (MPC, RANGE) or remote != self.addr:
            return False
        self.d.cancel_command()
        self.state = IDLE
        self.deadline = None
        metres = travel_s * self.d.sound_speed
        self.d._events.append((EV_RANGE, self.handle, remote, metres, {"travel_s": travel_s}))
        return True

    # -- time --------------------------------------------------------------------
    def _on_air(self, now, air_ms):
        d = self.d
        self.state = AIR
        # the end-of-transmission line is due after the airtime; allow the
        # retry wait on top before giving up on it
        self.deadline = ticks_add(now, air_ms + d.margin_ms)

    def _tx_done(self, now):
        if not self.tx_done_sent:
            self.tx_done_sent = True
            self.d._events.append((EV_TX_DONE, self.handle))
        if self.state in (TXD, AIR):
            if self.kind == K_DATA and self.ack:
                self.state = ACK
                self.deadline = ticks_add(now, self.d.ack_window_ms())
            else:
                self.state = IDLE
                self.deadline = None

    def poll(self, now):
        if self.deadline is None or ticks_diff(now, self.deadline) < 0:
            return
        st = self.state
        if st == DRQ:
            self.fail("no data request from the modem")
        elif st == TXD:
            self.fail("modem did not take the data")
        elif st == AIR:
            # the modem took the frame but its $CATXF never came: by the
            # airtime model it has left
            self._tx_done(now)
        elif st == ACK:
            self.fail("no acknowledgement")
        elif st == RANGE:
            self.state = IDLE
            self.deadline = None
            self.d._events.append((EV_RANGE, self.handle, None, None, {"reason": "no ping reply"}))

    # -- endings -------------------------------------------------------------------
    def fail(self, reason):
        if self.state == IDLE:
            return
        self.state = IDLE
        self.deadline = None
        self.d.cancel_command()
        self.d._events.append((EV_TX_FAILED, self.handle, reason))

    def error(self, reason):
        # $CAERR: ends the transaction unless our frame is already out and
        # only its acknowledgement is awaited (the error is about something
        # else then).
        if self.state != IDLE and self.state != ACK and self.state != RANGE:
            self.fail(reason)
            return True
        return False
