# Driver for Teledyne Benthos ATM-9xx acoustic modems (ATM-900 series) over
# their serial port: the CLAM shell with Hayes AT commands. Sans-IO: bytes
# and time in, bytes and events out (interface in acomm.drivers).
# docs/drivers-benthos.md says what goes on the wire and how the modem's
# answers map to acomm statuses.
#
# The modem has two modes. In command mode it takes one command line at a
# time (ending in CR) and answers with lines and its prompt `user:N>`. In
# online mode every byte is payload, sent acoustically once the line has
# been quiet for @FwdDelay. The driver keeps the modem in command mode, goes
# online only to hand over one frame (ATO, payload), and comes back with
# the modem's own prompt after the transmission, or with `+++` after a
# guard time of silence when it does not know the mode (start-up, errors).
#
# One command is outstanding at a time (the command slot, base.AcousticDriver); its
# owner is the configuration or the link's transaction (benthos_sequences),
# or a keepalive.

from .caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_RANGING, Capabilities
from ..compat import const, ticks_diff
from ..errors import AcommError, EncodeError
from ..events import EV_RX
from . import benthos_wire as w
from .benthos_sequences import (C_AT, C_ATO, C_ESCAPE, C_PAYLOAD, C_QUERY, C_RANGE, C_SET, IDLE, INFO, K_DATA, K_PING,
                                QUEUED, AcousticSlot, BenthosConfig, answer, setup_steps, stray)
from .base import S_CONFIG, S_START, S_UP, AcousticDriver


M_UNKNOWN = const(0)
M_COMMAND = const(1)
M_ONLINE = const(2)


_O_CONFIG = const(0)
_O_SLOT = const(1)
_O_PROBE = const(2)


class BenthosDriver(AcousticDriver):
    """A Teledyne Benthos ATM-9xx modem: frames in online mode (no delivery report), ATR ranging.

    Addresses are 0..249, 255 broadcasts; frames are 1..mtu bytes. Raises
    AcommError for settings out of range.
    """

    def __init__(
        self,
        address=None,
        tx_rate=8,
        mtu=w.DEFAULT_MTU,
        rx_max=256,
        fwd_delay_ms=50,
        rcv_all=True,
        ac_rsp_tmo_ms=10000,
        extra_settings=(),
        prompt_setting="P1Prompt",
        packet_ms=500,
        guard_ms=1300,
        cmd_timeout_ms=2000,
        prompt_timeout_ms=2000,
        range_margin_ms=2000,
        baud=9600,
        retry_ms=2000,
        alive_period_ms=60000,
        down_after=3,
        banner_marks=("Teledyne Benthos", "Benthos ATM"),
    ):
        AcousticDriver.__init__(self)
        if tx_rate not in w.RATES:
            raise AcommError("Benthos @TxRate codes are 2..13, not %r" % (tx_rate,))
        if not 1 <= mtu <= w.MAX_FRAME:
            raise AcommError("Benthos frames are 1..%d bytes, not %d" % (w.MAX_FRAME, mtu))
        if address is not None and not 0 <= address <= w.MAX_ADDR:
            raise AcommError("Benthos local addresses are 0..249, not %r" % (address,))
        if ac_rsp_tmo_ms is not None and not 2000 <= ac_rsp_tmo_ms <= 99500:
            raise AcommError("@AcRspTmOut is 2..99.5 s")
        self.address = address
        self.tx_rate = tx_rate
        self.mtu = mtu
        self.fwd_delay_ms = fwd_delay_ms
        self.packet_ms = packet_ms
        self.guard_ms = guard_ms
        self.cmd_timeout_ms = cmd_timeout_ms
        self.prompt_timeout_ms = prompt_timeout_ms
        # ATR waits for the modem's own timeout (or 10 s when it is left as
        # it is: an assumption) and a margin
        self.range_timeout_ms = (ac_rsp_tmo_ms or 10000) + range_margin_ms
        self.baud = baud
        self.alive_period_ms = alive_period_ms
        self.down_after = down_after
        self.banner_marks = banner_marks
        self.broadcast_addr = w.BROADCAST
        rx_max = max(rx_max, mtu)
        self.caps = Capabilities(
            manufacturer="Teledyne Benthos",
            model="ATM-900",
            mtu_tx=mtu,
            mtu_rx=rx_max,
            bitrate=w.RATES[tx_rate],
            # the frame's commands, forwarding delay and airtime, and about
            # 1 s of travel (1.5 km)
            latency_ms=fwd_delay_ms + self.airtime_ms(mtu) + 1000,
            flags=CAP_ADDRESSING | CAP_BROADCAST | CAP_RANGING,
        )
        steps = setup_steps(address, tx_rate, fwd_delay_ms, rcv_all, ac_rsp_tmo_ms, extra_settings, prompt_setting)
        self.config = BenthosConfig(self, steps, retry_ms)
        self.slot = AcousticSlot(self, mtu)
        self.remote = None  # the @RemoteAddr the modem last confirmed
        self.last_rx = None  # the receive statistics of the last good packet
        self.stats = {
            "cmd_timeouts": 0,
            "escapes": 0,
            "reboots": 0,
            "echo": 0,  # our own command lines echoed back
            "unknown": 0,  # well-formed lines that answer nothing
            "refused": 0,
        }
        self.junk = {}
        self._reader = w.LineReader(2 * rx_max + 32, self)
        self.rx = w.RxBlock(rx_max, self)
        self.mode = M_UNKNOWN
        self._owner = _O_CONFIG
        self._text = ""  # the command line, for echo and messages
        self.want = None  # (name, value) of a setting or query
        self._written = None  # when we last wrote to the modem
        self._probe_cmd = False  # the keepalive expects command mode

    # -- timing model ------------------------------------------------------------
    def airtime_ms(self, nbytes):
        return w.airtime_ms(self.tx_rate, nbytes, self.packet_ms)

    # -- the driver interface ------------------------------------------------------
    def send(self, now, addr, data, ack=False):
        """One frame to addr in online mode; it ends at EV_TX_DONE (or EV_TX_FAILED).

        ack is ignored: the modem reports no delivery (the link adds its own
        acks because the caps lack CAP_RELIABLE). Raises AcommError when not
        ready, EncodeError for a bad size or address.
        """
        if not self.ready(now):
            raise AcommError("Benthos modem not ready")
        n = len(data)
        if n > self.mtu:
            raise EncodeError("%d bytes exceed the Benthos MTU of %d" % (n, self.mtu))
        if n == 0:
            raise EncodeError("an empty frame cannot be sent in online mode")
        if not isinstance(addr, int) or not (0 <= addr <= w.MAX_ADDR or addr == w.BROADCAST):
            raise EncodeError("Benthos address %r outside 0..249 and 255" % (addr,))
        return self._accept(now, K_DATA, addr, data)

    def ping(self, now, addr):
        """ATR to addr: EV_RANGE (metres None when nobody answered). Never raises."""
        if not isinstance(addr, int) or not 0 <= addr <= w.MAX_ADDR or addr == self.address:
            return self._refuse("cannot range address %r" % (addr,))
        if not self.ready(now):
            return self._refuse("Benthos modem not ready")
        return self._accept(now, K_PING, addr, b"")

    def feed(self, now, data):
        """Bytes read from the device."""
        self._now = now
        self._reader.feed(data)
        self.slot.poll(now, self.mode == M_COMMAND)
        self._pump(now)

    def poll(self, now):
        """Let timers run: the command's and the transaction's deadlines, the escape's guard time, retries."""
        self._now = now
        if self._state == S_START:
            self._written = now  # the guard time counts from here
        self._begin(now)
        if self.cmd and ticks_diff(now, self._cmd_deadline) >= 0:
            self._cmd_timed_out(now)
        self.slot.poll(now, self.mode == M_COMMAND)
        self._pump(now)

    # -- writing -------------------------------------------------------------------
    def _write(self, now, data):
        self._out.extend(data)
        self._written = now

    def _command(self, now, kind, text, timeout_ms=None):
        self._text = text
        self._await(now, kind, timeout_ms if timeout_ms is not None else self.cmd_timeout_ms)
        self._write(now, text.encode())
        self._write(now, b"\r")

    def command_at(self, now, text):
        self.want = None
        self._command(now, C_AT, text)

    def command_set(self, now, name, value):
        self.want = (name, value)
        self._command(now, C_SET, "@%s=%s" % (name, value))

    def command_query(self, now, name):
        self.want = (name, "")
        self._command(now, C_QUERY, "@" + name)

    def command_ato(self, now):
        self._command(now, C_ATO, "ATO")

    def command_range(self, now, addr):
        self._command(now, C_RANGE, "ATR%d" % addr, self.range_timeout_ms)

    def command_payload(self, now, data):
        # online now: the bytes go out as they are; the modem answers
        # after the forwarding delay
        self.mode = M_ONLINE
        self._text = ""
        serial_ms = len(data) * 10000 // self.baud
        self._await(now, C_PAYLOAD, self.fwd_delay_ms + serial_ms + self.cmd_timeout_ms)
        self._write(now, data)

    def hold(self, until):
        self._hold_until = until

    def resync(self):
        # the modem's mode is not known: `+++` before the next command
        self.mode = M_UNKNOWN

    def _pump(self, now):
        # the next command, if the serial line is free: the escape when the
        # mode is unknown, then the start-up sequence, the link's
        # transaction, or a keepalive
        if self.cmd or self._held(now):
            return
        if self._state == S_START:
            return
        up = self._state == S_UP
        self._owner = _O_CONFIG
        if up:
            st = self.slot.state
            if st == QUEUED:
                self._owner = _O_SLOT
            elif st == IDLE:
                # Escape (harmless in either mode) to keep the modem in
                # command mode between transmissions, now and then to see
                # that it is still there, and at once after a command
                # went unanswered.
                self._probe_cmd = self.mode == M_COMMAND
                if self._silent or (self.alive_period_ms and ticks_diff(now, self._written) >= self.alive_period_ms):
                    self.mode = M_UNKNOWN
                if self.mode == M_COMMAND:
                    return
                self._owner = _O_PROBE
            else:
                return
        if self.mode != M_COMMAND:
            if ticks_diff(now, self._written) >= self.guard_ms:
                self.stats["escapes"] += 1
                self.want = None
                self._command(now, C_ESCAPE, "+++")
            return
        if up:
            self.slot.start(now)
        elif self._state == S_CONFIG:
            self.config.pump(now)

    # -- outcomes of commands ----------------------------------------------------------
    def _finish(self, now, kind, ok, detail):
        # the command kind ended (ok or not)
        self.cmd = 0
        if not ok:
            self.stats["refused"] += 1
        if kind == C_ESCAPE:
            self.mode = M_COMMAND
            if self._owner == _O_PROBE:
                return
        if self._owner == _O_SLOT:
            if kind != C_ESCAPE:
                self.slot.reply(now, ok, detail)
        elif self._owner == _O_CONFIG and kind != C_ESCAPE:
            self.config.reply(now, ok, detail)

    def _unanswered(self, now, kind):
        # the command kind timed out
        if kind == C_ESCAPE:
            # a modem whose prompt is not (yet) `user:N>` escapes silently:
            # carry on, the next command tells
            self._finish(now, kind, True, "")
        else:
            what = {C_ATO: "no CONNECT", C_PAYLOAD: "no " + w.FWD_UP}.get(kind)
            self.mode = M_UNKNOWN
            self._finish(now, kind, False, what or "no reply")

    # -- state changes -------------------------------------------------------------------
    def configured(self, now):
        """Called by the configuration when its last step is done: the driver is up."""
        self.remote = None
        AcousticDriver.configured(self, now)

    def lost(self, now, reason):
        """The modem restarted or fell silent: whatever it was doing is gone; configure it again."""
        self._went_down(reason)
        self.slot.lost(reason)
        self.remote = None
        self.mode = M_UNKNOWN
        self.rx.reset()
        self._set_up_again(now)

    # -- lines from the modem (LineReader and RxBlock sink) -----------------------------
    def on_junk(self, kind):
        self.junk[kind] = self.junk.get(kind, 0) + 1

    def on_block(self, src, dst, data, stats):
        self._heard_from(self._now)
        self.last_rx = stats
        self._events.append((EV_RX, src, dst, data))

    def on_line(self, raw, is_prompt):
        now = self._now
        for c in raw:
            if c < 32 or c > 126:
                self.on_junk("binary")
                return
        s = raw.decode().strip()
        if is_prompt:
            self._heard_from(now)
            self.rx.prompt()
            self._prompt(now)
            return
        if not s or self.rx.line(s):
            return
        for m in self.banner_marks:
            if m in s:
                self._heard_from(now)
                self.stats["reboots"] += 1
                self.lost(now, "modem rebooted")
                return
        if self.cmd and s == self._text:
            self.stats["echo"] += 1
            if self._state == S_UP:
                # the setup turned the echo off: the modem restarted
                # without a banner and lost its settings
                self.stats["reboots"] += 1
                self.lost(now, "modem restarted (its echo is back)")
            return
        if self._reply(now, s):
            self._heard_from(now)
        else:
            self.stats["unknown"] += 1

    def _prompt(self, now):
        kind = self.cmd
        if kind == C_ESCAPE:
            if self._owner == _O_PROBE and self._probe_cmd:
                # a keepalive found the modem online, where the driver
                # never leaves it (@OpMode=0): it restarted
                self.cmd = 0
                self.stats["reboots"] += 1
                self.lost(now, "modem restarted (found online)")
                return
            self._finish(now, kind, True, "")
        elif kind == C_PAYLOAD:
            # back at the shell without having said it transmits
            self.mode = M_COMMAND
            self._finish(now, kind, False, "no " + w.FWD_UP)
        elif not kind:
            self.mode = M_COMMAND  # after a transmission, or a restart
        # otherwise the prompt that followed the previous command

    def _reply(self, now, s):
        # True when s is an answer the driver knows
        r = answer(self.cmd, self.want[0] if self.want else "", self.slot.addr, s)
        if r is None:
            return stray(s)
        if r is not INFO:
            self._finish(now, self.cmd, r[0], r[1])
        return True
