# Selective-repeat ARQ for one packet on one hop: the sender's view
# (Outgoing) and the receiver's (Reassembly). Pure state machines with no
# link or clock of their own; acomm.transport drives them.
#
# The sender sends the missing fragments of a round in index order and sets
# the poll flag on the last one; the receiver answers a poll with one SACK:
# the count of fragments received in a row from 0 (base) and a bitmap of the
# MAX_BITMAP * 8 fragments after it. The next round holds only what is still
# missing, so a lost fragment costs its own airtime once more, not a window.
# A lost poll or SACK costs a timeout, then the poll goes again.

from . import segment as sg
from ..errors import DecodeError

WINDOW = 1 + 8 * sg.MAX_BITMAP  # fragments one SACK speaks for, from its base


class Outgoing:
    # blob: the packet header and body as sent, bytes or an object with
    # len() and read(offset, n) (acomm.transport.packetstore.StoredBlob: the body
    # stays in the store); fragsize: payload bytes per fragment on this hop.
    # reports: the modem's delivery reports acknowledge fragments
    # (acomm.transport.delivery.ReportedOutgoing)
    reports = False
    # The state that starts at a constant lives on the class until first set:
    # on MicroPython each attribute an instance sets can grow its table by a
    # reallocation, and a relaying buoy's fragmented heap failed those first.
    base = 0  # every fragment below is acknowledged
    round = ()  # indexes still to send in this round (replaced, never changed)
    sent_in_round = 0
    rounds = 0
    complete = False
    refused = None  # reason byte when the receiver refused
    probing = False  # see probe()

    def __init__(self, blob, fragsize, lane, gen, pid):
        if fragsize < 1:
            raise ValueError("fragment size must be positive")
        # blob.read is looked up per fragment, not kept: one attribute less,
        # so the table of a packet's usual 12 fields never grows to 17 slots
        # (136 B) at its completion, in a step (a board's fragmented heap failed there)
        self.blob = blob
        self.fragsize = fragsize
        self.count = (len(blob) + fragsize - 1) // fragsize
        if self.count - 1 > sg.MAX_INDEX:
            raise ValueError("%d fragments, at most %d" % (self.count, sg.MAX_INDEX + 1))
        self.lane = lane
        self.gen = gen
        self.pid = pid
        self.acked = bytearray(self.count)

    def fragment(self, index, poll):
        # -> (head, bytes): see acomm.transport.segment; bytes None when the blob
        # could not be read back (its store lost a record)
        start = index * self.fragsize
        head, first = sg.frag_header(poll, self.lane, self.gen, index)
        blob = self.blob
        if not hasattr(blob, "read"):  # bytes (hasattr makes no bound method)
            return head, first + blob[start : start + self.fragsize]
        part = blob.read(start, self.fragsize)
        return head, None if part is None else first + part

    def new_round(self):
        # The missing fragments the next SACK can speak for.
        top = self.base + WINDOW
        if top > self.count:
            top = self.count
        self.round = [i for i in range(self.base, top) if not self.acked[i]]
        self.sent_in_round = 0
        self.rounds += 1
        return self.round

    def probe(self):
        # The first transfer on a lane since this node started with packets
        # from its store: the receiver may still hold, on this lane and
        # generation, a transfer of the node's previous life (it lost power
        # mid-transfer), and fragments of the new packet would be taken as
        # that one's. So the first round is a bare poll: a SACK of nothing
        # means the lane is clear; one that acknowledges anything, refuses,
        # or completes another packet is stale, and the transfer starts over
        # on the other generation. One round trip per lane after such a start.
        self.probing = True
        self.round = [0]
        self.sent_in_round = 0

    def next_fragment(self):
        # -> (index, head, bytes) of the next fragment of the round, poll
        # set on the last one; None when the round is all sent.
        if self.sent_in_round >= len(self.round):
            return None
        i = self.round[self.sent_in_round]
        self.sent_in_round += 1
        if self.probing:
            head, first = sg.frag_header(True, self.lane, self.gen, i)
            return i, head, first
        return (i,) + self.fragment(i, self.sent_in_round == len(self.round))

    def repoll(self):
        # after a timeout: a bare poll (the index byte, no fragment bytes).
        # The SACK it brings says what is missing; sending the last
        # fragment again instead would cost a full frame's airtime each
        # time a short SACK was lost.
        i = self.round[-1] if self.round else self.count - 1
        head, first = sg.frag_header(True, self.lane, self.gen, i)
        return i, head, first

    def on_sack(self, s):
        # s: a decoded SACK segment for this lane and generation. Returns
        # True when it told us something (the round is over).
        if s.complete:
            if s.reason is not None:
                if self.probing:
                    return False  # nothing sent yet: a refusal of another transfer
                self.refused = s.reason
                return True
            if s.pid != self.pid or s.base != self.count & 0xFF:
                return False  # a stale completion of an earlier packet
            self.complete = True
            for i in range(self.count):
                self.acked[i] = 1
            self.base = self.count
            return True
        base = sg.unwrap(s.base, self.base)
        if self.probing:
            # anything acknowledged is of another transfer
            self.probing = False
            return base == 0 and not any(s.bitmap)
        if base >= self.count:
            # A plain SACK never speaks for a whole packet: the receiver
            # answers a finished one with its completion (count and pid).
            # This one is about another transfer the receiver still holds
            # on this lane and generation: ours restarted (a power loss)
            # and reused them. Taking it as ours "delivered" a packet the
            # receiver never had (the soak found one in 24 h).
            return False
        if base < 0:
            base = 0
        for i in range(self.base, base):
            self.acked[i] = 1
        bm = s.bitmap
        for k in range(len(bm)):
            b = bm[k]
            if not b:
                continue
            for j in range(8):
                if b & (1 << j):
                    i = base + 1 + 8 * k + j
                    if i < self.count:
                        self.acked[i] = 1
        while self.base < self.count and self.acked[self.base]:
            self.base += 1
        if self.base == self.count:
            # Acks of earlier SACKs say all is there and this one says the
            # receiver lacks fragments from its base on: it lost them (its
            # reassembly timed out, or it restarted). Those it does not list
            # go again; trusting the old acks let a transfer "complete" that
            # the receiver never had.
            for i in range(base, self.count):
                k = i - base - 1
                self.acked[i] = 1 if k >= 0 and (k >> 3) < len(bm) and bm[k >> 3] & (1 << (k & 7)) else 0
            self.base = base
        return True


class Reassembly:
    # One packet arriving on one lane from one neighbour. Memory: the
    # fragments received, at most max_bytes in all. The state that starts at
    # a constant lives on the class until first set (as in Outgoing).
    size = 0
    count = None
    header = None
    done_pid = None  # set once complete: the packet id we confirmed
    _base = 0  # fragments 0.._base-1 have all arrived
    unauthed = False  # a fragment came without a valid tag (acomm.frame.auth)
    refused = None  # the reason this transfer was refused, kept for polls

    def __init__(self, gen, max_bytes, now):
        self.gen = gen
        self.max_bytes = max_bytes
        self.frags = {}
        self.touched = now

    def add(self, index, payload, now):
        # Raises DecodeError for a fragment that contradicts the packet.
        self.touched = now
        if self.done_pid is not None or index in self.frags:
            return
        if index < 0:
            # an index byte read as before the packet's start: garbage
            # (complete() counts fragments, so it must never hold one)
            raise DecodeError("fragment index %d" % index)
        if self.count is not None and index >= self.count:
            raise DecodeError("fragment %d of a %d-fragment packet" % (index, self.count))
        if self.size + len(payload) > self.max_bytes:
            raise DecodeError("fragments overrun %d bytes" % self.max_bytes)
        self.frags[index] = bytes(payload)
        self.size += len(payload)
        while self._base in self.frags:
            self._base += 1
        if index == 0:
            # when the packet's header came: a relay takes the rest of the
            # transfer's time off the life that header gave (stamped when the
            # sender queued this copy of fragment 0)
            self.born = now
            h = sg.decode_packet_header(payload)
            total = h.size + h.length
            if total > self.max_bytes:
                raise DecodeError("packet of %d bytes, at most %d" % (total, self.max_bytes))
            fs = len(payload)
            self.count = 1 if total <= fs else (total + fs - 1) // fs
            self.header = h
            if total < fs or any(i >= self.count for i in self.frags):
                raise DecodeError("fragments beyond the declared length")

    def complete(self):
        return self.count is not None and len(self.frags) == self.count

    def blob(self):
        # the packet bytes in order; checks the length the header declared
        out = b"".join(self.frags[i] for i in range(self.count))
        h = self.header
        if len(out) != h.size + h.length:
            raise DecodeError("packet of %d bytes, header says %d" % (len(out), h.size + h.length))
        return out

    def base(self):
        return self._base

    def index_of(self, low):
        # the fragment index a segment's index byte (mod 256) stands for
        return sg.unwrap(low, self.count if self.done_pid is not None else self._base)

    def bitmap(self):
        b = self.base()
        top = b + 1
        out = bytearray(sg.MAX_BITMAP)
        last = -1
        for k in range(sg.MAX_BITMAP):
            for j in range(8):
                if (top + 8 * k + j) in self.frags:
                    out[k] |= 1 << j
                    last = k
        return b, bytes(out[: last + 1])
