# The emulated Iridium network behind emulated SBD modems: the gateway that
# takes MO messages from sessions and keeps MT messages for each modem until
# a session fetches them, on injected time.
#
# Where an MO message goes (a RockBLOCK-to-RockBLOCK relay, ref 5.3):
#   1. a payload that starts with b"RB" and the 7-digit serial of a modem on
#      this network goes to that modem, without the prefix;
#   2. else the route table, if it has the sender's IMEI (route(src, dst));
#   3. else every other modem on the network (a fleet whose vendor
#      application forwards each message to all its other members).
# Every MO message is also kept in `mo_log` (bounded), which is what a shore
# application would read, and given to each of `shores`, fn(now, imei,
# serial, momsn, mtmsn, data): the gateway's delivery to customers' servers
# (DirectIP, the RockBLOCK POST; acomm_cpython.emulate.shoregw). The message arrives in the destination's MT
# queue at the gateway after a latency of 5 s for a short message up to
# 20 s for the longest (ref 5.4); the gateway then sends a ring alert, and
# one more after ring_repeat_ms if no session came (ref 5.2), then waits
# for a mailbox check. MT queues are bounded: the oldest is dropped.
#
# emulator(medium) finds the network of a medium (an IridiumNetwork itself,
# or one made once and kept on any other object, such as the acoustic
# medium of a World or of `acomm emulate`).

from acomm.compat import ticks_add, ticks_diff

from .atmodem import shared_network

_LOG_MAX = 100


class IridiumNetwork:
    def __init__(self, min_latency_ms=5000, max_latency_ms=20000, mt_capacity=50, ring_repeat_ms=20000):
        self.min_latency_ms = min_latency_ms
        self.max_latency_ms = max_latency_ms
        self.mt_capacity = mt_capacity
        self.ring_repeat_ms = ring_repeat_ms
        self.modems = {}  # IMEI -> emulator
        self.routes = {}  # IMEI -> [IMEI, ...]
        self.mt = {}  # IMEI -> [bytes, ...] waiting at the gateway
        self.mo_log = []  # (ticks, IMEI, bytes), newest last
        self.shores = []  # fn(now, imei, serial, momsn, mtmsn, data) for each MO message
        self.dropped = 0
        self._flight = []  # [arrival, IMEI, bytes]
        self._rings = []  # [when, IMEI]: the repeated ring alert

    def attach(self, emu):
        self.modems[emu.imei] = emu
        self.mt.setdefault(emu.imei, [])

    def route(self, src_imei, dst_imei):
        self.routes.setdefault(src_imei, []).append(dst_imei)

    def latency_ms(self, n):
        span = self.max_latency_ms - self.min_latency_ms
        return self.min_latency_ms + span * min(n, 340) // 340

    def mo(self, now, emu, data):
        # a session delivered an MO message from emu
        self.mo_log.append((now, emu.imei, data))
        if len(self.mo_log) > _LOG_MAX:
            self.mo_log.pop(0)
        for fn in self.shores:
            # the session's MOMSN, which the modem counted before this call
            fn(now, emu.imei, emu.serial, emu.momsn, emu.mtmsn, data)
        dst = None
        if len(data) >= 9 and data[:2] == b"RB":
            for m in self.modems.values():
                if m.serial.encode() == data[2:9]:
                    dst, data = [m.imei], data[9:]
                    break
        if dst is None:
            dst = self.routes.get(emu.imei)
        if dst is None:
            dst = [k for k in self.modems if k != emu.imei]
        at = ticks_add(now, self.latency_ms(len(data)))
        for imei in dst:
            self._flight.append([at, imei, data])

    def queue_mt(self, now, imei, data):
        # a message for imei arrives at the gateway now (a shore
        # application, `acomm emulate iridium --mt`)
        self._flight.append([now, imei, bytes(data)])
        self.poll(now)

    def take_mt(self, imei):
        # for a session: (the oldest MT message or None, how many remain)
        q = self.mt.get(imei)
        if not q:
            return None, 0
        self._rings = [r for r in self._rings if r[1] != imei]
        return q.pop(0), len(q)

    def queued(self, imei):
        return len(self.mt.get(imei, ()))

    def busy(self):
        return bool(self._flight or self._rings)

    def poll(self, now):
        if self._flight:
            keep = []
            for f in self._flight:
                if ticks_diff(now, f[0]) >= 0:
                    self._arrive(now, f[1], f[2])
                else:
                    keep.append(f)
            self._flight = keep
        if self._rings:
            due = [r for r in self._rings if ticks_diff(now, r[0]) >= 0]
            if due:
                self._rings = [r for r in self._rings if r not in due]
                for r in due:
                    m = self.modems.get(r[1])
                    if m is not None and self.queued(r[1]):
                        m.ring_alert(now)

    def _arrive(self, now, imei, data):
        q = self.mt.get(imei)
        if q is None:
            self.dropped += 1  # no such modem
            return
        q.append(data)
        if len(q) > self.mt_capacity:
            q.pop(0)
            self.dropped += 1
        m = self.modems[imei]
        m.ring_alert(now)
        self._rings = [r for r in self._rings if r[1] != imei]
        self._rings.append([ticks_add(now, self.ring_repeat_ms), imei])


def network_of(medium):
    return shared_network(medium, IridiumNetwork, "iridium_network")
