# The soak's accounting of transport packets: every packet a node's
# Transport.send() accepted must end with exactly one final status at its
# origin (delivered, expired or failed) and at most one delivery at its
# destination, with the bytes that were sent.
#
# Packets are numbered by the soak (seq) and carry that number in their
# first four bytes, so a delivery names its packet; statuses name it by
# (origin, packet id). A packet whose origin was told `transmitted` (a relay
# took custody) and that the relay then let expire or fail is told only at
# the relay (EV_RELAY_STATUS): it counts as expired or failed there, not
# lost. Memory: two bits per packet ever sent (bytearrays), a dict entry
# while a packet has no final status, and one for each packet that went
# into a relay's custody, kept until a relay reports it (a delivery names
# the packet by its seq, not its key): tens a day in the soak, so the
# ledger does not grow the peak it helps to measure.

from acomm.events import DELIVERED, EXPIRED, FAILED, TRANSMITTED

_D, _F, _X = 1, 2, 4  # flags per seq: delivered once, final status seen, never accepted


class Ledger:
    def __init__(self):
        self.flags = bytearray()
        self.final = bytearray()  # seq -> final status (0 while none)
        self.open = {}  # (origin id, pid) -> seq, until its final status
        self.custody = {}  # (origin id, pid) -> seq, for the packets a relay took (`transmitted`)
        self._sending = None  # (origin, seq) while send() runs
        self.counts = {"accepted": 0, "refused_store_full": 0, "delivered": 0, "duplicates": 0, "corrupt": 0,
                       "status_delivered": 0, "status_expired": 0, "status_failed": 0, "extra_final": 0,
                       "late_delivery": 0, "expired_at_relay": 0, "failed_at_relay": 0, "relay_unknown": 0}

    def begin(self, origin):
        # -> seq of the packet about to be handed to origin's send(); its
        # first status (queued, or failed "store full") comes from inside
        # send(), before the pid is returned, and is bound to it here
        self.flags.append(0)
        self.final.append(0)
        seq = len(self.flags) - 1
        self._sending = (origin, seq)
        return seq

    def sent(self, seq, origin, pid):
        # send() returned pid for packet seq
        self._sending = None
        if self.open.get((origin, pid)) != seq and not self.flags[seq] & _F:
            self.open[(origin, pid)] = seq
        if self.final[seq] == FAILED:
            self.counts["refused_store_full"] += 1  # refused at once, final already
        else:
            self.counts["accepted"] += 1

    def not_sent(self, seq):
        # send() raised: nothing was accepted
        self._sending = None
        self.flags[seq] |= _X

    def status(self, origin, pid, st):
        s = self._sending
        if s is not None and s[0] == origin and (origin, pid) not in self.open:
            self.open[(origin, pid)] = s[1]
        if st not in (DELIVERED, TRANSMITTED, EXPIRED, FAILED):
            return
        seq = self.open.pop((origin, pid), None)
        if seq is None:
            self.counts["extra_final"] += 1  # a second final status, or one for nothing sent
            return
        if st == TRANSMITTED:
            self.custody[(origin, pid)] = seq
        self._final(seq, st)

    def relay_status(self, origin, pid, st):
        # a relay let a packet of origin's that it took custody of expire, or failed it
        seq = self.custody.pop((origin, pid), None)
        if seq is None or st not in (EXPIRED, FAILED):
            self.counts["relay_unknown"] += 1
            return
        self.final[seq] = st
        self.counts["expired_at_relay" if st == EXPIRED else "failed_at_relay"] += 1

    def _final(self, seq, st):
        self.flags[seq] |= _F
        self.final[seq] = st
        k = {DELIVERED: "status_delivered", TRANSMITTED: "status_delivered", EXPIRED: "status_expired",
             FAILED: "status_failed"}[st]
        self.counts[k] += 1

    def delivered(self, seq, intact):
        if not 0 <= seq < len(self.flags):
            self.counts["corrupt"] += 1
            return
        if self.flags[seq] & _D:
            self.counts["duplicates"] += 1
            return
        if not intact:
            self.counts["corrupt"] += 1
        self.flags[seq] |= _D
        self.counts["delivered"] += 1
        if self.final[seq] in (EXPIRED, FAILED):
            self.counts["late_delivery"] += 1  # fine: reported, and then it came

    def pending(self):
        return len(self.open)

    def lost(self):
        # accepted, never delivered, and not reported expired or failed
        # (a `delivered` status without a delivery is a loss too)
        n = 0
        for seq in range(len(self.flags)):
            f = self.flags[seq]
            if not f & (_D | _X) and self.final[seq] not in (EXPIRED, FAILED):
                n += 1
        return n
