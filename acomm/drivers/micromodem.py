# Driver for the WHOI Micro-Modem (MM1 / MM2) over its NMEA 0183 serial
# interface. Sans-IO: bytes and time in, bytes and events out (interface in
# acomm.drivers). docs/drivers-micromodem.md says what goes on the wire, how
# the modem's answers map to acomm statuses, and which facts are unconfirmed.
#
# Two things are tracked apart:
#   the command slot   one $CC sentence awaiting its echo; resent after
#                      modem_wait_ms up to `retries` times, then the modem
#                      counts as lost (EV_DRIVER_DOWN, start-up again);
#   the acoustic slot  one data frame, mini-packet or ping from the moment
#                      the link hands it over until its end (micromodem_sequences).
# Received frames, mini-packets and reboots arrive at any time in between.

from .caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_RANGING, CAP_RELIABLE, Capabilities
from ..compat import ticks_add
from ..errors import AcommError, EncodeError
from ..events import EV_RX
from . import micromodem_wire as w
from .micromodem_sequences import ECHO, K_DATA, K_MINI, K_PING, AcousticSlot, MicroModemConfig
from .micromodem_wire import BITRATE, FRAME_BYTES, Airtime, advert_to_mini, check_rate, mini_to_advert
from .base import S_CONFIG, AcousticDriver


class MicroModemDriver(AcousticDriver):
    """A WHOI Micro-Modem: one frame per cycle (acknowledged or not), adverts as mini-packets, pings.

    Addresses are 0..max_addr (broadcast_addr is everyone); frames are 1 to
    the rate's frame size. Raises AcommError for settings out of range.
    """

    # a command is resent `retries` times before it counts as unanswered,
    # so the first unanswered one already says the modem is gone
    down_after = 1

    def __init__(
        self,
        address=None,
        rate=1,
        broadcast_addr=0,
        max_addr=15,
        mini_adverts=True,
        sound_speed=1500.0,
        max_range_m=2000,
        mini_ms=700,
        fsk_gap_ms=800,
        psk_ms=1000,
        air_scale=1.0,
        turnaround_ms=250,
        margin_ms=2000,
        modem_wait_ms=5000,
        retries=3,
        reboot_wait_ms=2000,
        retry_ms=2000,
        query_src=None,
        clock=None,
        csum32=w.CSUM32_VERIFY,
    ):
        AcousticDriver.__init__(self)
        check_rate(rate)
        if not 0 <= max_addr <= 254 or not 0 <= broadcast_addr <= max_addr:
            raise AcommError("Micro-Modem addresses: broadcast %r outside 0..%r" % (broadcast_addr, max_addr))
        if address is not None and (not 0 <= address <= max_addr or address == broadcast_addr):
            raise AcommError("Micro-Modem address %r outside 0..%d or broadcast" % (address, max_addr))
        self.rate = rate
        self.broadcast_addr = broadcast_addr
        self.max_addr = max_addr
        self.mini_adverts = mini_adverts
        self.sound_speed = sound_speed
        self.max_range_m = max_range_m
        self.air = Airtime(mini_ms, fsk_gap_ms, psk_ms, air_scale)
        self.turnaround_ms = int(turnaround_ms * air_scale)
        self.margin_ms = margin_ms
        self.modem_wait_ms = modem_wait_ms
        self.retries = retries
        self.reboot_wait_ms = reboot_wait_ms
        mtu = FRAME_BYTES[rate]
        self.caps = Capabilities(
            manufacturer="WHOI",
            model="Micro-Modem",
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=BITRATE[rate],
            latency_ms=self.air.packet_ms(rate, mtu) + self.air.travel_ms(max_range_m, sound_speed),
            flags=CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING,
        )
        self.own_addr = address  # until the modem says otherwise
        self.info = {}  # firmware version from $CAREV
        self.config = MicroModemConfig(self, address, query_src, clock, retry_ms)
        self.stats = {
            "reboots": 0,
            "cmd_timeouts": 0,  # $CC sentences that went unanswered in time (resent or given up)
            "errors": 0,  # $CAERR lines
            "stale": 0,  # echoes and requests that match nothing we wait for
            "malformed": 0,
            "unknown": 0,
            "bad_crc": 0,  # $CAMSG,BAD_CRC: a packet heard but damaged
            "packet_timeout": 0,
            "mini_ignored": 0,  # mini-packets that are not acomm adverts
            "pinged": 0,  # $CAMPA: the modem answered someone's ping
        }
        self._reader = w.LineReader(self, csum32=csum32)
        self._cmd_line = b""  # the sentence in the command slot (which awaits its echo, e.g. b"CACYC")
        self._cmd_tries = 0
        self.slot = AcousticSlot(self)

    # -- timing model ------------------------------------------------------------
    def round_trip_ms(self):
        return 2 * self.air.travel_ms(self.max_range_m, self.sound_speed)

    def ack_window_ms(self):
        # after our packet ends: the way to the farthest node, its turn-
        # around and its ack (a mini-packet), the way back, and a margin
        return self.round_trip_ms() + self.turnaround_ms + self.air.mini_ms() + self.margin_ms

    def ping_window_ms(self):
        # after the echo: our ping, the round trip, the reply
        return self.round_trip_ms() + self.turnaround_ms + 2 * self.air.mini_ms() + self.margin_ms

    # -- the driver interface ----------------------------------------------------
    @property
    def address(self):
        return self.own_addr

    @property
    def junk(self):
        return self._reader.junk

    def send(self, now, addr, data, ack=False):
        """One frame in a cycle to addr (ack: $CAACK gives EV_DELIVERED); a plain advert goes as a mini-packet.

        Raises AcommError when not ready, EncodeError for a bad size or
        address.
        """
        if not self.ready(now):
            raise AcommError("Micro-Modem not ready")
        n = len(data)
        if n > self.caps.mtu_tx:
            raise EncodeError("%d bytes exceed the Micro-Modem MTU of %d at rate %d" % (n, self.caps.mtu_tx, self.rate))
        if n == 0:
            raise EncodeError("an empty $CCTXD means 'no data': nothing to send")
        if not isinstance(addr, int) or not 0 <= addr <= self.max_addr or addr == self.own_addr:
            raise EncodeError("Micro-Modem address %r outside 0..%d (or our own)" % (addr, self.max_addr))
        if addr == self.broadcast_addr:
            ack = False  # nobody acknowledges a broadcast
        h = self._handle()
        mini = advert_to_mini(data, self.own_addr) if (self.mini_adverts and not ack) else None
        if mini is not None:
            self.slot.start(now, h, K_MINI, addr, mini=mini)
        else:
            self.slot.start(now, h, K_DATA, addr, bytes(data), ack)
        return h

    def ping(self, now, addr):
        """$CCMPC to addr: EV_RANGE from the travel time (metres None without a reply). Never raises."""
        if not isinstance(addr, int) or not 0 <= addr <= self.max_addr or addr in (self.broadcast_addr, self.own_addr):
            return self._refuse("cannot ping address %r" % (addr,))
        if not self.ready(now):
            return self._refuse("Micro-Modem not ready")
        h = self._handle()
        self.slot.start(now, h, K_PING, addr)
        return h

    # -- the command slot ----------------------------------------------------------
    def write(self, line):
        self._out.extend(line)

    def command(self, now, line, expect):
        # writes the sentence line; the slot waits for the echo `expect`
        self._out.extend(line)
        self._cmd_line = line
        self._cmd_tries = 0
        self._await(now, expect, self.modem_wait_ms)

    def cancel_command(self):
        self.cmd = 0

    def _cmd_timed_out(self, now):
        # resent up to `retries` times before it counts as unanswered
        if self._cmd_tries < self.retries:
            self._cmd_tries += 1
            self.stats["cmd_timeouts"] += 1
            self._out.extend(self._cmd_line)
            self._cmd_deadline = ticks_add(now, self.modem_wait_ms)
            return
        AcousticDriver._cmd_timed_out(self, now)

    def _unanswered(self, now, what):
        why = "no answer to $%s" % self._cmd_line[1:6].decode()
        if self._state == S_CONFIG:
            self.config.failed(now, why)
        else:
            self.slot.fail(why)

    def _next_command(self, now):
        pass  # the acoustic slot writes its sentences itself

    # -- state changes -------------------------------------------------------------
    def lost(self, now, reason, wait_ms=0):
        """The modem rebooted or fell silent: whatever it was doing is gone; configure it again after wait_ms."""
        self._went_down(reason)
        self.slot.fail(reason)
        self._set_up_again(now, wait_ms)

    # -- sentences from the modem (LineReader sink) ----------------------------------
    def on_junk(self, kind):
        pass  # counted by the reader; the transaction's own timers recover

    def on_sentence(self, buf, n):
        now = self._now
        f = w.fields(buf, n)
        name = f[0]
        if self.cmd and name == self.cmd:
            if self._state == S_CONFIG:
                if self.config.answer(now, f):
                    self.cmd = 0
                else:
                    self.stats["stale"] += 1
                return
            if self.slot.state in ECHO and ECHO[self.slot.state] == name and self._echo_matches(f):
                self.cmd = 0
                self.slot.echoed(now, name)
                return
        handler = _HANDLERS.get(name)
        if handler is None:
            self.stats["unknown"] += 1
            return
        handler(self, now, f)

    def _echo_matches(self, f):
        # $CACYC,0,src,dst,...: field 3 is the destination; $CAMUC/$CAMPC:
        # src,dst,... with the destination in field 2
        i = 3 if f[0] == b"CACYC" else 2
        return len(f) > i and w.num(f[i]) == self.slot.addr

    def _rev(self, now, f):
        # $CAREV,HHMMSS,IDENT,VERSION: INIT means the modem has just restarted
        if len(f) < 3:
            self.stats["malformed"] += 1
            return
        if f[2] == b"INIT":
            self.stats["reboots"] += 1
            self.lost(now, "modem rebooted", self.reboot_wait_ms)
        elif len(f) >= 4:
            self.info[w.text(f[2])] = w.text(f[3])

    def _err(self, now, f):
        # $CAERR,HHMMSS,MODULE,NUM,MESSAGE
        self.stats["errors"] += 1
        module = w.text(f[2]) if len(f) > 2 else "?"
        msg = w.text(f[4]) if len(f) > 4 else ""
        reason = "modem error %s: %s" % (module, msg) if msg else "modem error %s" % module
        if self._state == S_CONFIG and self.cmd:
            self.cmd = 0
            self.config.failed(now, reason)
        elif self.slot.error(reason):
            pass

    def _drq(self, now, f):
        # $CADRQ,HHMMSS,SRC,DEST,ACK,NBYTES,FRAME#
        if len(f) < 7:
            self.stats["malformed"] += 1
            return
        if not self.slot.data_request(now, w.num(f[3]), w.num(f[5], 0, 4096)):
            # not for a cycle of ours (one we gave up on): the modem will
            # report DATA_TIMEOUT and go back to idle by itself
            self.stats["stale"] += 1

    def _tx(self, now, f):
        if not self.slot.transmitting(now, f[0]):
            self.stats["stale"] += 1

    def _ack(self, now, f):
        # $CAACK,SRC,DEST,FRAME#,1
        if len(f) < 4 or w.num(f[1]) is None or w.num(f[2]) is None:
            self.stats["malformed"] += 1
            return
        if not self.slot.acked(now, w.num(f[1]), w.num(f[2]), w.num(f[3])):
            self.stats["stale"] += 1

    def _rxd(self, now, f):
        # $CARXD,SRC,DEST,ACK,FRAME#,HEX
        if len(f) < 6:
            self.stats["malformed"] += 1
            return
        src = w.num(f[1], 0, 254)
        dst = w.num(f[2], 0, 254)
        data = w.unhex(f[5])
        if src is None or dst is None or not data:
            self.stats["malformed"] += 1
            return
        self._events.append((EV_RX, src, dst, data))

    def _mua(self, now, f):
        # $CAMUA,SRC,DEST,HHHH: a mini-packet heard
        if len(f) < 4:
            self.stats["malformed"] += 1
            return
        src = w.num(f[1], 0, 254)
        dst = w.num(f[2], 0, 254)
        value = w.unhex(f[3]) if len(f[3]) == 4 else None
        if src is None or dst is None or value is None:
            self.stats["malformed"] += 1
            return
        frame = mini_to_advert((value[0] << 8) | value[1], src)
        if frame is None:
            self.stats["mini_ignored"] += 1
            return
        self._events.append((EV_RX, src, dst, frame))

    def _mpr(self, now, f):
        # $CAMPR,REMOTE,US,TRAVEL: one-way travel time in seconds
        remote = w.num(f[1], 0, 254) if len(f) >= 4 else None
        travel = w.real(f[3]) if len(f) >= 4 else None
        if remote is None or travel is None or travel < 0:
            self.stats["malformed"] += 1
            return
        if not self.slot.ranged(now, remote, travel):
            self.stats["stale"] += 1

    def _msg(self, now, f):
        # $CAMSG,BAD_CRC,... / PACKET_TIMEOUT,...: receptions that failed
        if len(f) >= 2 and f[1] == b"BAD_CRC":
            self.stats["bad_crc"] += 1
        elif len(f) >= 2 and f[1] == b"PACKET_TIMEOUT":
            self.stats["packet_timeout"] += 1

    def _campa(self, now, f):
        self.stats["pinged"] += 1

    def _quiet(self, now, f):
        pass  # known, nothing to do: someone's cycle, a packet detected, ...

    def _late(self, now, f):
        self.stats["stale"] += 1  # an echo or config answer nobody waits for


_HANDLERS = {
    b"CAREV": MicroModemDriver._rev,
    b"CAERR": MicroModemDriver._err,
    b"CADRQ": MicroModemDriver._drq,
    b"CATXD": MicroModemDriver._tx,
    b"CATXP": MicroModemDriver._tx,
    b"CATXF": MicroModemDriver._tx,
    b"CAACK": MicroModemDriver._ack,
    b"CARXD": MicroModemDriver._rxd,
    b"CAMUA": MicroModemDriver._mua,
    b"CAMPR": MicroModemDriver._mpr,
    b"CAMSG": MicroModemDriver._msg,
    b"CAMPA": MicroModemDriver._campa,
    b"CARXP": MicroModemDriver._quiet,
    b"CACYC": MicroModemDriver._quiet,
    b"CAXST": MicroModemDriver._quiet,
    b"CACST": MicroModemDriver._quiet,
    b"CACFG": MicroModemDriver._late,
    b"CACLK": MicroModemDriver._late,
    b"CAMUC": MicroModemDriver._late,
    b"CAMPC": MicroModemDriver._late,
}
