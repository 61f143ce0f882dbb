# Driver for a GSM modem sending and receiving SMS (3GPP TS 27.005 over AT),
# ref/modem-protocols.md section 6. Sans-IO (interface in acomm.drivers).
# docs/drivers-sms.md says what goes on the wire and how the answers map to
# acomm statuses.
#
# Addresses: the driver's address for a peer is its node id; it is given a
# table node id -> phone number (`numbers`) and turns the sender's number of
# a received message back into a node id (unknown senders are dropped and
# counted). The network addresses and checks messages itself, so the caps
# have CAP_ADDRESSING: the link sends elided frames (one header byte) and
# passes the destination's node id to send(). There is no broadcast.
#
# PDU mode (default): an SMS-SUBMIT with 8-bit data (DCS 0x04): up to 140
# bytes of frame. Text mode: the frame in base64 (sms_wire), 120 bytes.
#
# One message at a time: AT+CMGS (length, or "number"), the "> " prompt, the
# PDU in hex (or the text) and Ctrl-Z, then "+CMGS: <mr>" OK -> EV_TX_DONE
# (accepted by the network, not delivered); +CMS ERROR -> EV_TX_FAILED with
# the error. Received messages are announced by +CMTI (AT+CNMI=2,1,0,0,0)
# and found by listing the storage (AT+CMGL) at start and every
# list_period_ms; each is read (AT+CMGR), handed up, and deleted (AT+CMGD).
# While the signal is 0 or unknown (99) nothing is sent (AtDriver).
#
# Unsolicited lines a SIM800 or an EC2x prints at any time (their power-up
# lines, registration reports, calls) are URCs: never taken for the answer
# to a command. "RDY" (banner_marks) is a restart: configure again; the
# other power-up lines (+CFUN: 1, +CPIN: READY, Call Ready, SMS Ready,
# +QIND, +QUSIM) follow it and are counted only. "+CPIN: <not READY>" (SIM
# removed or failed) configures the modem again once the line is free, so
# that the driver is down until AT+CPIN? says READY.
#
# Time: AT+CCLK? once the modem is up and every time_period_ms (0: never).
# The modem's clock is the network's time (NITZ) where the network sends
# it; a clock the network never set shows the unit's power-up date, taken
# as no time (sms_wire.parse_cclk). Each time read goes to the node's wall
# clock (AtDriver.take_times), uncertain by 2 s.

from .caps import CAP_ADDRESSING, Capabilities
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError, EncodeError
from ..events import EV_RX, EV_TX_DONE, EV_TX_FAILED
from . import sms_pdu as pdu
from . import sms_wire as w
from .atcommand import R_OK, R_TIMEOUT, after
from .atdriver import AtDriver
from .base import IDLE, QUEUED

SENDING = const(2)
K_SMS = const(0)

T_CMGS = const(10)
T_CMGR = const(11)
T_CMGD = const(12)
T_CMGL = const(13)

_CCLK_UNC_MS = const(2000)  # acomm.drivers.sms_wire: the uncertainty of an AT+CCLK? time
_TRIES = const(2)  # reads and deletes that time out are tried this often


class SmsDriver(AtDriver):
    """A GSM modem sending one SMS per frame to a peer's number (node id -> number table); no broadcast.

    EV_TX_DONE means the network took it (+CMGS). Raises AcommError when
    not ready, EncodeError for a broadcast, an address without a number or
    a bad size.
    """

    time_spec = (b"AT+CCLK?", "gsm", _CCLK_UNC_MS)
    parse_time = staticmethod(w.parse_cclk)

    def __init__(
        self,
        address=None,
        numbers=None,
        pdu_mode=True,
        smsc=None,
        validity=None,
        cnmi=True,
        list_period_ms=300000,
        cost_tx=0.001,
        cost_rx=0.0,
        latency_ms=10000,
        bitrate=200,
        min_rssi=1,
        cmd_timeout_ms=5000,
        prompt_timeout_ms=5000,
        send_timeout_ms=60000,
        give_up_ms=600000,
        csq_timeout_ms=5000,
        csq_period_ms=60000,
        csq_retry_ms=20000,
        retry_ms=5000,
        down_after=3,
        read_capacity=16,
        banner_marks=(b"RDY",),
        time_period_ms=3600000,
    ):
        steps = [(b"ATE0Q0V1", None, None), (b"AT+CMEE=1", None, None),
                 (b"AT+CPIN?", b"+CPIN: READY", None), (b"AT+CMGF=%d" % (0 if pdu_mode else 1), None, None)]
        if not pdu_mode:
            steps.append((b'AT+CSCS="GSM"', None, None))
        if cnmi:
            steps.append((b"AT+CNMI=2,1,0,0,0", None, None))
        steps.append((b"AT+CSQ", b"+CSQ", csq_timeout_ms))
        mtu = pdu.UD_MAX if pdu_mode else w.TEXT_MTU
        urcs = (b"+CMTI:", b"+CDSI:", b"+CIEV:", b"+CREG:", b"+CGREG:", b"+CPIN:", b"+CFUN:", b"Call Ready",
                b"SMS Ready", b"+QIND:", b"+QUSIM:", b"RING", b"+CRING:", b"+CLIP:", b"NO CARRIER")
        AtDriver.__init__(self, steps, urcs, mtu, 400, 0, cmd_timeout_ms, retry_ms, down_after, csq_period_ms,
                          csq_retry_ms, csq_timeout_ms, banner_marks)
        self.address = address  # our own node id: the destination of what arrives
        self.time_period_ms = time_period_ms
        self.broadcast_addr = None
        self.pdu_mode = pdu_mode
        self.smsc = smsc
        self.validity = validity
        self.min_rssi = min_rssi
        self.list_period_ms = list_period_ms
        self.prompt_timeout_ms = prompt_timeout_ms
        self.send_timeout_ms = send_timeout_ms
        self.give_up_ms = give_up_ms
        self.read_capacity = read_capacity
        self.numbers = {}
        self._ids = {}  # digits -> node id
        for nid in numbers or {}:
            self.set_number(nid, numbers[nid])
        self._bitrate = bitrate
        self.caps = Capabilities(
            manufacturer="GSM",
            model="SMS (%s mode)" % ("PDU" if pdu_mode else "text"),
            cost_tx=cost_tx,
            cost_rx=cost_rx,
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=0,  # until the modem reports signal
            latency_ms=latency_ms,
            flags=CAP_ADDRESSING,
        )
        self.last_error = None
        self.stats.update({
            "sent": 0, "send_failed": 0, "received": 0, "rx_bad": 0, "rx_unknown_sender": 0, "rx_not_binary": 0,
            "read_overflow": 0, "deleted": 0, "malformed": 0, "urcs_other": 0, "sim_lost": 0,
        })
        self._read = []  # storage indices to read, oldest first
        self._delete = []  # indices read, to delete
        self._tries = 0
        self._first_at = 0  # when the message in the slot was accepted
        self._list_at = None  # None: list at once
        self._prompted = False
        self._mr = None
        self._hdr = None
        self._body = None
        self._sim = None  # why to configure again ("+CPIN: NOT READY"), once the line is free

    def set_number(self, node_id, number):
        if not isinstance(number, str) or not number.lstrip("+").isdigit():
            raise AcommError("phone number %r is not digits with an optional +" % (number,))
        self.numbers[node_id] = number
        self._ids[number.lstrip("+")] = node_id

    def node_of(self, number):
        return self._ids.get(number.lstrip("+"))

    # -- the driver interface ------------------------------------------------------
    def send(self, now, addr, data, ack=False):
        # ack is ignored: the network reports no delivery here (the link
        # sends its own acks because the caps lack CAP_RELIABLE)
        if not self.ready(now):
            raise AcommError("GSM modem not ready")
        if addr is None:
            raise EncodeError("SMS has no broadcast")
        if addr not in self.numbers:
            raise EncodeError("no phone number for node %r" % (addr,))
        n = len(data)
        if not 1 <= n <= self.caps.mtu_tx:
            raise EncodeError("an SMS carries 1..%d bytes, not %d" % (self.caps.mtu_tx, n))
        self._first_at = now
        return self._accept(now, K_SMS, addr, data)

    parse_signal = staticmethod(w.parse_csq)

    def _signal_ok(self, rssi):
        return rssi != 99 and rssi >= self.min_rssi

    # -- what to do next -------------------------------------------------------------
    def _tick(self, now):
        # a message that cannot leave (no signal, no modem) fails in time
        s = self.slot
        if s.state == QUEUED and ticks_diff(now, self._first_at) >= self.give_up_ms:
            s.state = IDLE
            self.stats["send_failed"] += 1
            self._events.append((EV_TX_FAILED, s.handle, self.stuck_reason() or "not sent in time"))

    def _work(self, now):
        at = self.at
        s = self.slot
        if self._sim is not None:
            self.lost(now, self._sim)
            self._pump(now)  # the start-up's first command
            return True
        if self._delete:
            at.command(now, b"AT+CMGD=%d" % self._delete[0], T_CMGD, self.cmd_timeout_ms)
            return True
        if self._read:
            self._hdr = self._body = None
            at.command(now, b"AT+CMGR=%d" % self._read[0], T_CMGR, self.cmd_timeout_ms)
            return True
        if s.state == QUEUED and self.signal_ok:
            self._send(now)
            return True
        if self._list_at is None or (self.list_period_ms and ticks_diff(now, self._list_at) >= 0):
            at.command(now, b"AT+CMGL=4" if self.pdu_mode else b'AT+CMGL="ALL"', T_CMGL, self.cmd_timeout_ms)
            return True
        return False

    def _send(self, now):
        s = self.slot
        s.state = SENDING
        self._prompted = False
        self._mr = None
        number = self.numbers[s.addr]
        if self.pdu_mode:
            p, n = pdu.encode_submit(number, s.buf[: s.n], pdu.DCS_8BIT, self.validity, self.smsc)
            self._payload = pdu.to_hex(p)
            cmd = b"AT+CMGS=%d" % n
        else:
            self._payload = w.encode_text(s.buf[: s.n])
            cmd = b'AT+CMGS="%s"' % number.encode()
        self.at.command(now, cmd, T_CMGS, self.prompt_timeout_ms, prompt=b">")

    def _prompt(self, now, tag):
        if tag != T_CMGS or self._prompted:
            self.stats["unexpected"] += 1
            return
        self._prompted = True
        self.at.write(self._payload + b"\x1a", now, self.send_timeout_ms)

    def _block(self, now, tag, buf, n):
        self.stats["unexpected"] += 1

    # -- answers ---------------------------------------------------------------------
    def _info(self, tag, line):
        if tag == T_CMGS:
            self._mr = w.parse_mr(line)
            return self._mr is not None
        if tag == T_CMGR:
            if self._hdr is None and line.startswith(b"+CMGR:"):
                self._hdr = line
            elif self._hdr is not None and self._body is None:
                self._body = line
            else:
                return False
            return True
        if tag == T_CMGL:
            if line.startswith(b"+CMGL:"):
                i = w.parse_index(line, b"+CMGL:")
                if i is None:
                    self.stats["malformed"] += 1
                else:
                    self._want(i)
            return True  # the message lines under each +CMGL
        return False

    def _result(self, now, tag, code, line):
        if tag == T_CMGS:
            self._sent(now, code, line)
        elif tag == T_CMGR:
            if code == R_TIMEOUT and self._retry():
                return
            if code == R_OK and self._hdr is not None:
                if not self._deliver() and self._retry():
                    return  # damaged on the serial line, perhaps: read it again
                i = self._read[0]
                if i not in self._delete:
                    self._delete.append(i)
            self._read.pop(0)
            self._tries = 0
        elif tag == T_CMGD:
            if code == R_TIMEOUT and self._retry():
                return
            self._delete.pop(0)
            self._tries = 0
            if code == R_OK:
                self.stats["deleted"] += 1
        elif tag == T_CMGL:
            self._list_at = ticks_add(now, self.list_period_ms if code != R_TIMEOUT else self.retry_ms)

    def _retry(self):
        self._tries += 1
        return self._tries < _TRIES

    def _sent(self, now, code, line):
        s = self.slot
        if s.state != SENDING:
            return
        s.state = IDLE
        if code == R_OK:
            self.stats["sent"] += 1
            self._events.append((EV_TX_DONE, s.handle))
            return
        if code == R_TIMEOUT:
            if not self._prompted:
                # a prompt we missed would swallow the next command: ESC
                # leaves it without sending
                self.at.write(b"\x1b\r")
            why = "no +CMGS reply" if self._prompted else "no > prompt"
        else:
            why = line.decode()
        self.last_error = why
        self.stats["send_failed"] += 1
        self._events.append((EV_TX_FAILED, s.handle, why))

    def _deliver(self):
        # The message just read: to the link when it is a frame from a node
        # we know. False when it could not be decoded.
        st = self.stats
        try:
            if self.pdu_mode:
                if self._body is None:
                    raise DecodeError("no PDU line")
                raw = pdu.from_hex(self._body)
                n = w.cmgr_pdu_length(self._hdr)
                if n is None or n != len(raw) - 1 - raw[0]:
                    raise DecodeError("PDU length does not match its +CMGR header")
                number, dcs, data, _, hdr = pdu.decode_deliver(raw)
                if pdu.alphabet(dcs) != 1 or hdr is not None:
                    st["rx_not_binary"] += 1
                    return True
            else:
                number = w.cmgr_sender(self._hdr)
                if number is None:
                    raise DecodeError("no sender in the +CMGR header")
                data = w.decode_text(self._body or b"")
        except DecodeError:
            st["rx_bad"] += 1
            return False
        src = self.node_of(number)
        if src is None:
            st["rx_unknown_sender"] += 1
            return True
        if not data:
            st["rx_bad"] += 1
            return False
        st["received"] += 1
        self._events.append((EV_RX, src, self.address, data))
        return True

    def _want(self, i):
        # one more stored message to read; when too many wait, the next
        # listing finds the rest
        if i in self._read or i in self._delete:
            return
        if len(self._read) >= self.read_capacity:
            self.stats["read_overflow"] += 1
            self._list_at = ticks_add(self._now, self.retry_ms)
            return
        self._read.append(i)

    def _urc(self, now, line):
        if line.startswith(b"+CMTI:"):
            i = w.parse_index(line, b"+CMTI:")
            if i is None:
                self.stats["malformed"] += 1
            else:
                self._want(i)
        elif line.startswith(b"+CPIN:") and after(line, b"+CPIN:") != b"READY":
            self.stats["sim_lost"] += 1
            self._sim = "SIM not ready (%s)" % line.decode()
        else:
            self.stats["urcs_other"] += 1

    def _lost(self, now, reason):
        # A message being sent when the modem restarted may or may not
        # have left: it fails here (the link retries an acknowledged one).
        s = self.slot
        if s.state == SENDING:
            s.state = IDLE
            self.stats["send_failed"] += 1
            self._events.append((EV_TX_FAILED, s.handle, reason))
        self._tries = 0
        self._list_at = None
        self._sim = None
