# Driver for Blueprint Subsea SeaTrac X110/X150 beacons (acoustic modem and
# USBL), over their serial command interface. Sans-IO: bytes and time in,
# bytes and events out (interface in acomm.drivers). docs/drivers.md says
# what goes on the wire and how the beacon's answers map to acomm statuses.
#
# Two things can be outstanding at once, and they are tracked apart:
#   the command slot   one serial command awaiting its same-CID response
#                      (answered at once by a live beacon, or timed out);
#   the acoustic slot  one DAT_SEND or PING_SEND, from the moment the link
#                      hands it over until its ack, error or timeout.
# The link sees ready() only through the acoustic slot; housekeeping
# (keepalive, reboot probes) queues behind or ahead of it on the command
# slot without ever blocking the link.
#
# queue_reply() keeps a packet in the beacon (DAT_QUEUE_SET) for its next
# automatic reply to a DAT request: an interrogated node answers with data
# without a transmission of its own (seed 003 section 6).

from .caps import Capabilities
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, EncodeError
from . import seatrac_wire as w
from .seatrac_sequences import REQ_TYPES, AcousticSlot, SeatracConfig
from .base import AcousticDriver

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_CAP_ADDRESSING = const(1)  # acomm.drivers.caps
_CAP_BROADCAST = const(4)  # acomm.drivers.caps
_CAP_RANGING = const(16)  # acomm.drivers.caps
_CAP_RELIABLE = const(2)  # acomm.drivers.caps
_CMD = const(2)  # acomm.drivers.seatrac_sequences
_K_DAT = const(0)  # acomm.drivers.seatrac_sequences
_K_PING = const(1)  # acomm.drivers.seatrac_sequences
_IDLE = const(0)  # acomm.drivers.base
_QUEUED = const(1)  # acomm.drivers.base
_S_CONFIG = const(1)  # acomm.drivers.base
_S_UP = const(2)  # acomm.drivers.base

# seatrac_codes' numbers, as private constants (inlined: no RAM on a board)
_BEACON_ALL = const(0)
_CID_DAT_ERROR = const(0x63)
_CID_DAT_QUEUE_CLR = const(0x65)
_CID_DAT_QUEUE_SET = const(0x64)
_CID_DAT_RECEIVE = const(0x61)
_CID_DAT_SEND = const(0x60)
_CID_PING_ERROR = const(0x43)
_CID_PING_REQ = const(0x41)
_CID_PING_RESP = const(0x42)
_CID_PING_SEND = const(0x40)
_CID_SETTINGS_GET = const(0x15)
_CID_SETTINGS_SAVE = const(0x18)
_CID_SETTINGS_SET = const(0x16)
_CID_STATUS = const(0x10)
_CID_SYS_ALIVE = const(0x01)
_CID_SYS_INFO = const(0x02)
_CID_SYS_REBOOT = const(0x03)
_CST_FAIL = const(0x01)
_CST_OK = const(0x00)
_FIX_RANGE = const(0x01)
_JUNK_TEXT = const(1)
_MAX_MSG = const(128)
_MSG_OWAY = const(0)
_MSG_REQU = const(4)
_SYNC_CMD = const(0x23)
_SYNC_RSP = const(0x24)

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_REPLIED = const(8)
_EV_RX = const(1)


# answers to commands (ours, late, or someone else's on the line)
_COMMANDS = (
    _CID_SYS_REBOOT,
    _CID_SETTINGS_GET,
    _CID_SETTINGS_SET,
    _CID_SETTINGS_SAVE,
    _CID_DAT_SEND,
    _CID_PING_SEND,
    _CID_DAT_QUEUE_SET,
    _CID_DAT_QUEUE_CLR,
)


class SeatracDriver(AcousticDriver):
    """A SeaTrac beacon: DAT_SEND frames (acknowledged with MSG_REQU), PING_SEND ranging, USBL fixes.

    Addresses are beacon ids 1..15 (15 also broadcasts); frames are 1..mtu
    bytes. Raises AcommError for settings out of range.
    """

    def __init__(
        self,
        beacon_id=None,
        mtu=30,
        ack_type=_MSG_REQU,
        oway_type=_MSG_OWAY,
        ping_type=_MSG_REQU,
        set_beacon_id=True,
        settings_len=110,
        id_offset=96,
        packet_ms=500,
        byte_ms=80,
        turnaround_ms=300,
        range_tmo_m=1000,
        vos=1500,
        resp_time_ms=10,
        cmd_timeout_ms=1500,
        margin_ms=2000,
        busy_backoff_ms=1000,
        alive_period_ms=60000,
        probe_gap_ms=500,
        retry_ms=2000,
        reboot_wait_ms=2000,
        down_after=3,
    ):
        AcousticDriver.__init__(self)
        if not 1 <= mtu <= 31:
            raise AcommError("SeaTrac DAT payloads are 1..31 bytes, not %d" % mtu)
        if beacon_id is not None and not 1 <= beacon_id <= 15:
            raise AcommError("SeaTrac beacon ids are 1..15, not %r" % (beacon_id,))
        self.mtu = mtu
        self.ack_type = ack_type
        self.oway_type = oway_type
        self.ping_type = ping_type
        self.packet_ms = packet_ms
        self.byte_ms = byte_ms
        self.turnaround_ms = turnaround_ms
        self.range_tmo_m = range_tmo_m
        self.vos = vos
        self.resp_time_ms = resp_time_ms
        self.cmd_timeout_ms = cmd_timeout_ms
        self.margin_ms = margin_ms
        self.busy_backoff_ms = busy_backoff_ms
        self.alive_period_ms = alive_period_ms
        self.probe_gap_ms = probe_gap_ms
        self.down_after = down_after
        self.caps = Capabilities(
            manufacturer="Blueprint Subsea",
            model="SeaTrac",
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=8000 // byte_ms,
            latency_ms=2 * packet_ms + turnaround_ms + byte_ms * mtu,
            flags=_CAP_ADDRESSING | _CAP_BROADCAST | _CAP_RELIABLE | _CAP_RANGING,
        )
        self.broadcast_addr = _BEACON_ALL
        self.config = SeatracConfig(self, beacon_id, set_beacon_id, settings_len, id_offset, retry_ms, reboot_wait_ms)
        self.last_fix = None  # the latest ACO_FIX with a range, as a dict
        # the reply packet: what the host wants queued (dest, data or None),
        # whether that still has to be written, what the beacon confirmed
        self._q_want = None
        self._q_dirty = False
        self._q_sent = None
        self.queued_reply = None
        self.queue_problem = None  # the CST_E name of a refused DAT_QUEUE_SET
        self.stats = {
            "cmd_timeouts": 0,
            "reboots": 0,
            "stale": 0,  # answers, acks and errors that match nothing we wait for
            "malformed": 0,
            "unknown": 0,  # messages with a CID we do not know
            "statuses": 0,
            "queue_refused": 0,
        }
        self._reader = w.LineReader(_SYNC_RSP, self)
        self._msg = bytearray(_MAX_MSG)
        self._line = bytearray(2 * _MAX_MSG + 8)
        self._up_s = None  # beacon uptime (s) at self._up_at
        self._up_at = 0
        self.slot = AcousticSlot(self)

    # -- timing model ------------------------------------------------------
    def airtime_ms(self, nbytes):
        return self.packet_ms + self.byte_ms * nbytes

    def reply_window_ms(self):
        # from the end of our packet to the end of the remote's automatic
        # reply at the range limit: the beacon's own response timeout
        return 2 * self.range_tmo_m * 1000 // self.vos + self.resp_time_ms + self.turnaround_ms + self.airtime_ms(0)

    # -- the driver interface ----------------------------------------------
    @property
    def beacon_id(self):
        return self.config.own_id

    def send(self, now, addr, data, ack=False):
        """One DAT_SEND to beacon addr (15: everyone, one-way); ack asks for the remote's automatic reply.

        Raises AcommError when not ready, EncodeError for a bad size or id.
        """
        if not self.ready(now):
            raise AcommError("SeaTrac not ready")
        n = len(data)
        if n > self.mtu:
            raise EncodeError("%d bytes exceed the SeaTrac MTU of %d" % (n, self.mtu))
        if not isinstance(addr, int) or not 0 <= addr <= 15:
            raise EncodeError("SeaTrac beacon id %r outside 0..15" % (addr,))
        if addr == _BEACON_ALL:
            mtype = self.oway_type  # broadcasts are one-way only
        else:
            mtype = self.ack_type if ack else self.oway_type
        return self._accept(now, _K_DAT, addr, mtype, data)

    def ping(self, now, addr):
        """A PING_SEND to beacon addr: EV_RANGE with the USBL fix. Never raises (the link calls it unguarded)."""
        if not isinstance(addr, int) or not 1 <= addr <= 15:
            return self._refuse("cannot ping beacon id %r" % (addr,))
        if not self.ready(now):
            return self._refuse("SeaTrac not ready")
        return self._accept(now, _K_PING, addr, self.ping_type, b"")

    def queue_reply(self, now, data, dest=_BEACON_ALL):
        # The packet for the beacon's next automatic reply to a DAT request
        # from dest (0: from anyone); None clears it. Written ahead of the
        # link's next frame: it must be in the beacon before someone asks.
        if data is not None and len(data) > 31:
            raise EncodeError("%d bytes exceed the SeaTrac reply packet of 31" % len(data))
        if not 0 <= dest <= 15:
            raise EncodeError("SeaTrac beacon id %r outside 0..15" % (dest,))
        self._q_want = (dest, None if data is None else bytes(data))
        self._q_dirty = True
        self._pump(now)

    def _slot_gave_up(self, now):
        self._probe = True  # silent: did it restart?

    @property
    def junk(self):
        return self._reader.junk

    # -- writing commands --------------------------------------------------
    def command(self, now, cid, n):
        # Writes self._msg[:n] (CID already at [0]) and occupies the slot.
        self._msg[0] = cid
        k = w.encode_into(self._line, _SYNC_CMD, self._msg, n)
        self._out.extend(memoryview(self._line)[:k])
        self._await(now, cid, self.cmd_timeout_ms)

    def _next_command(self, now):
        # The command slot is free and the beacon up: the reply packet
        # first, then the link's frame, then probes.
        if self._q_dirty:
            self._q_dirty = False
            self._q_sent = q = self._q_want
            if q[1] is None:
                self.command(now, _CID_DAT_QUEUE_CLR, 1)
            else:
                m = self._msg
                m[1] = q[0]
                m[2] = len(q[1])
                m[3 : 3 + len(q[1])] = q[1]
                self.command(now, _CID_DAT_QUEUE_SET, 3 + len(q[1]))
            return
        if self.slot.state == _QUEUED and not self._held(now):
            cid, n = self.slot.build(self._msg)
            self.command(now, cid, n)
            return
        if self._probe_due(now):
            self.command(now, _CID_SYS_ALIVE, 1)

    def _unanswered(self, now, cid):
        # the command cid timed out
        if cid == _CID_DAT_QUEUE_SET or cid == _CID_DAT_QUEUE_CLR:
            self._q_dirty = True  # write it again once the beacon answers
        if self._state == _S_CONFIG:
            self.config.failed(now, "no response to command 0x%02X" % cid)
            return
        slot = self.slot
        if slot.state == _CMD:
            # The command may have been carried out and only its answer
            # lost: hold the next one until the beacon would be idle again.
            self._hold_until = ticks_add(now, slot.busy_ms())
            slot.fail("no response to %s" % ("PING_SEND" if slot.kind == _K_PING else "DAT_SEND"))

    # -- state changes -----------------------------------------------------
    def lost(self, now, reason):
        """The beacon rebooted or fell silent: whatever it was doing is gone; configure it again."""
        self._went_down(reason)
        if self.slot.state != _IDLE:
            self.slot.fail(reason)
        self.queued_reply = None  # the beacon's RAM is gone: queue it again
        self._q_dirty = self._q_want is not None and self._q_want[1] is not None
        self._set_up_again(now)

    def uptime(self, now, secs, expected_reboot=False):
        # Seconds since power-up reported by the beacon. Fewer than the last
        # report plus the time since then (with slack for the 1 s resolution
        # and clock drift) means it restarted behind our back.
        prev = self._up_s
        elapsed = ticks_diff(now, self._up_at)
        self._up_s = secs
        self._up_at = now
        if prev is None or expected_reboot or self._state != _S_UP:
            return False
        if secs * 1000 + 2000 + elapsed // 100 < prev * 1000 + elapsed:
            self.stats["reboots"] += 1
            self.lost(now, "modem rebooted")
            return True
        return False

    def forget_uptime(self):
        self._up_s = None

    # -- messages from the beacon (LineReader sink) -------------------------
    def on_junk(self, kind):
        # Text outside messages is what a rebooting beacon prints: ask it
        # how long it has been up. Damaged lines are only counted.
        if kind == _JUNK_TEXT and self._state == _S_UP:
            self._probe = True

    def on_message(self, b, n):
        now = self._now
        cid = b[0]
        self._heard_from(now)
        if cid == self.cmd:
            self.cmd = 0
            if self._state == _S_CONFIG:
                self.config.response(now, b, n)
            elif cid == _CID_DAT_SEND or cid == _CID_PING_SEND:
                if self.slot.state == _CMD and n >= 2:
                    hold = self.slot.command_status(now, b[1])
                    if hold is not None:
                        self._hold_until = hold
                else:
                    self.stats["stale"] += 1
            elif cid == _CID_SYS_ALIVE and n >= 5:
                self.uptime(now, w.u32(b, 1))
            elif cid == _CID_DAT_QUEUE_SET or cid == _CID_DAT_QUEUE_CLR:
                st = b[1] if n >= 2 else _CST_FAIL  # a trailing DEST_ID is tolerated
                if st == _CST_OK:
                    self.queued_reply = self._q_sent[1]
                else:
                    self.stats["queue_refused"] += 1
                    self.queue_problem = w.status_name(st)
            return
        if cid == _CID_DAT_RECEIVE:
            self._dat_receive(now, b, n)
        elif cid == _CID_DAT_ERROR or cid == _CID_PING_ERROR:
            kind = _K_DAT if cid == _CID_DAT_ERROR else _K_PING
            if n >= 3 and self.slot.awaiting(kind, b[2]):
                if kind == _K_PING:
                    self.slot.ranged(None, None, {"status": w.status_name(b[1])})
                else:
                    self.slot.dat_error(b[1])
            else:
                self.stats["stale"] += 1
        elif cid == _CID_PING_RESP:
            self._ping_resp(b, n)
        elif cid == _CID_PING_REQ:
            self._answering(now)
        elif cid == _CID_SYS_ALIVE or cid == _CID_SYS_INFO:
            # unsolicited: some firmware announces itself after a restart
            if n >= 5:
                self.uptime(now, w.u32(b, 1))
        elif cid == _CID_STATUS:
            self.stats["statuses"] += 1
            if n >= 10:
                # TIMESTAMP: u64 ms since power-up (high word * 2**32 / 1000
                # in seconds, kept in small ints)
                self.uptime(now, w.u32(b, 2) // 1000 + w.u32(b, 6) * 4294967)
        elif cid in _COMMANDS:
            self.stats["stale"] += 1
        else:
            self.stats["unknown"] += 1

    def _answering(self, now):
        # Our beacon heard a request for it and replies by itself; it would
        # refuse a command of ours as busy meanwhile.
        self._hold_until = ticks_add(now, self.turnaround_ms + self.resp_time_ms + self.airtime_ms(0))

    def _dat_receive(self, now, b, n):
        fl = w.fix_len(b, 1, n)
        k = 1 + fl
        if fl < 0 or k + 2 > n:
            self.stats["malformed"] += 1
            return
        ack = b[k]
        plen = b[k + 1]
        extra = n - (k + 2 + plen)
        if extra < 0 or extra > 1 or plen > 31:  # extra: the newer LOCAL_FLAG
            self.stats["malformed"] += 1
            return
        dest = b[1]
        src = b[2]
        own = self.config.own_id
        if ack:
            if self.slot.awaiting(_K_DAT, src) and (own is None or dest == own):
                if b[3] & _FIX_RANGE:
                    self.last_fix = w.fix_dict(b, 1)
                self.slot.delivered()
            else:
                self.stats["stale"] += 1
            if not plen:
                return
        if src == 0 or src > 15:  # 0 is "unknown" as a source
            self.stats["malformed"] += 1
            return
        self._events.append((_EV_RX, src, dest, bytes(b[k + 2 : k + 2 + plen])))
        if not ack and b[4] in REQ_TYPES and own is not None and dest == own:
            self._answering(now)
            q = self._q_want
            if q is not None and q[0] in (_BEACON_ALL, src) and self.queued_reply is not None:
                # the beacon's reply took the packet
                self._q_want = self.queued_reply = None
                self._events.append((_EV_REPLIED,))

    def _ping_resp(self, b, n):
        if w.fix_len(b, 1, n) < 0:
            self.stats["malformed"] += 1
            return
        src = b[2]
        if not self.slot.awaiting(_K_PING, src):
            self.stats["stale"] += 1
            return
        fix = w.fix_dict(b, 1)
        metres = fix.get("range")
        if metres is not None:
            self.last_fix = fix
        self.slot.ranged(src, metres, fix)
