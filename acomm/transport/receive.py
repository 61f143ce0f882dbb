# The receiving half of the transport (acomm.transport): fragments in,
# reassembly per (link, neighbour, lane), selective acknowledgements out,
# whole packets up (or into the store, at a relay).
#
# Bounds: at most _MAX_RX reassemblies at a time (a sender beyond that is
# refused "receiver full" and tries again later), each of at most
# max_packet bytes, dropped after _RX_TIMEOUT_MS without a fragment; the
# last DONE_MEMORY delivered (origin, packet id) pairs, so a packet sent
# again (its SACK was lost, or the sender restarted before it came) is
# acknowledged and not delivered twice. They are kept in the store too
# (acomm.transport.packetstore), so a receiver that restarts still knows them.

from . import segment as sg
from .arq import Reassembly
from ..compat import const, ticks_diff
from ..errors import DecodeError, StoreFull
from ..frame import SEGMENT
from .packetstore import DONE_MEMORY

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_PACKET = const(27)
_EV_REFUSED = const(28)
_FAILED = const(8)
_TRANSMITTED = const(4)

_SACK_PRIORITY = const(2)
_RX_TIMEOUT_MS = const(600000)
_MAX_RX = const(8)


class _Room:
    # what the store's overflow rule needs to judge a packet not yet whole
    __slots__ = ("size", "prio", "medium")


class Receiving:
    def __init__(self):
        self._rx = {}  # (link name, src id, lane) -> Reassembly
        self._done = []  # (origin, pid) delivered here lately
        self._sacks = {}  # link request id -> (link, neighbour id, SACK bytes, tries)
        self._quiet = False  # the segment at hand is unsealed, strict mode: no SACK for it

    def _rx_poll(self, now):
        for k in [k for k in self._rx if ticks_diff(now, self._rx[k].touched) > _RX_TIMEOUT_MS]:
            del self._rx[k]

    def on_segment(self, now, link, src, dst, head, payload, authed=False):
        try:
            s = sg.decode(head, payload)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return
        key = (link.name, src, s.lane)
        g = self.node.guard
        # strict mode (acomm.link.guard): 0 refused, 2 unsealed (taken, never answered)
        v = 1 if g is None or not g.strict else g.admits_segment(self._rx, key, s, authed)
        if not v:
            return
        self._quiet = v == 2
        if s.is_sack:
            self.stats["sacks"] += 1
            self._on_sack(now, link, src, s)
            return
        r = self._rx.get(key)
        if not s.payload:
            self._answer_poll(now, link, src, s, r)
            return
        if r is None or r.gen != s.gen:
            if len(self._rx) >= _MAX_RX:
                self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, sg.REFUSE_FULL))
                return
            r = self._rx[key] = Reassembly(s.gen, self.max_packet + 16, now)
        index = r.index_of(s.index)
        if r.refused is not None:
            if index != 0:
                if s.poll:
                    self._answer_poll(now, link, src, s, r)
                return  # the rest of a refused transfer: dropped
            # a fragment 0 starts the packet over: judged afresh (and a
            # forged refusal cannot block the real sender's lane)
            r = self._rx[key] = Reassembly(s.gen, self.max_packet + 16, now)
        if not authed:
            r.unauthed = True  # the packet is as trusted as its weakest fragment
        try:
            first = r.header is None
            r.add(index, s.payload, now)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return self._refuse(now, link, src, s, key, sg.REFUSE_TOO_BIG)
        if first and r.header is not None and not self._can_take(r.header):
            # a relay without room says so before the rest is sent
            return self._refuse(now, link, src, s, key, sg.REFUSE_FULL)
        if r.done_pid is None and r.complete():
            if not self._arrived(now, link, src, r):
                return self._refuse(now, link, src, s, key, sg.REFUSE_FULL)
        if s.poll or (r.done_pid is not None and index == r.count - 1):
            self._answer_poll(now, link, src, s, r)

    def _refuse(self, now, link, src, s, key, reason):
        # The fragments go, a marker stays: the refusal may be sent while
        # the sender is still on the air with the rest of its round (half-
        # duplex: deaf), so its poll gets the refusal again, not "all
        # missing", which would have it send everything once more.
        m = Reassembly(s.gen, 0, now)
        m.refused = reason
        m.unauthed = self._rx[key].unauthed
        self._rx[key] = m
        self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, reason))

    def _answer_poll(self, now, link, src, s, r):
        if r is None or r.gen != s.gen:
            # a bare poll for a transfer we have nothing of (our memory of
            # it timed out, or this node restarted): all is missing
            self._sack(now, link, src, sg.sack(s.lane, s.gen, 0))
        elif r.refused is not None:
            self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, r.refused))
        elif r.done_pid is not None:
            self._sack(now, link, src, sg.sack_complete(s.lane, s.gen, r.count, r.done_pid))
        else:
            b, bm = r.bitmap()
            self._sack(now, link, src, sg.sack(s.lane, s.gen, b, bm))

    def _can_take(self, h):
        if h.relay is None or h.relay[1] == self.node.node_id:
            return True  # for this node: delivered, never stored
        q = _Room()
        q.size, q.prio, q.medium = h.length, h.relay[2], None
        if self.packets.room(q):
            return True
        self.stats["store_full"] += 1
        return False

    def _arrived(self, now, link, src, r):
        # -> False when a packet to relay found no room in the store
        try:
            blob = r.blob()
            h = r.header
            body = blob[h.size :]
            if h.relay is not None:
                origin, final, prio, life = h.relay
            else:
                origin, final, prio, life = src, self.node.node_id, 8, 3600
        except DecodeError:
            return self._bad(r)
        if final != self.node.node_id:
            # a relay keeps the body as the origin sent it: it is not
            # decompressed here (the fragments' CRCs already vouch for the
            # bytes, and the destination checks the rest)
            if (origin, h.pid) not in self._done:
                p = self._packet(origin, final, h.pid, prio, self.wall() + life, body, h.compressed, None)
                if not self._keep(p):
                    return False
                self.stats["relayed"] += 1
                self._remember(origin, h.pid)
        elif (origin, h.pid) in self._done:
            self.stats["rx_dup"] += 1
        else:
            data = body
            if h.compressed:
                # imported here: a relay that only forwards never loads it
                from ..codec.compress import decompress

                try:
                    data = decompress(body, self.max_packet)
                except DecodeError:
                    return self._bad(r)
            self._remember(origin, h.pid, False)
            names = self.node.names
            g = self.node.guard
            if g is not None and not g.admits(data, not r.unauthed, self.node.auth):
                self.stats["refused_unauthed"] += 1
                self._emit((_EV_REFUSED, None, names.name_of(origin), g.REFUSED))
            else:
                self.stats["received"] += 1
                ev = (_EV_PACKET, names.name_of(origin), names.name_of(final), data)
                self._emit(ev if g is None else ev + (not r.unauthed,))
            # saved after the application has it: a power cut in between
            # gives at worst a second delivery, never a packet acknowledged
            # that nobody saw
            self._save_done()
        r.done_pid = h.pid
        r.frags = {}  # the memory goes; the lane remembers only the completion
        return True

    def _bad(self, r):
        self.stats["rx_bad"] += 1
        r.frags.clear()
        r.size = 0
        r.count = None
        r.header = None
        return True

    def _remember(self, origin, pid, save=True):
        self._done.append((origin, pid))
        if len(self._done) > DONE_MEMORY:
            self._done.pop(0)
        if save:
            self._save_done()

    def _save_done(self):
        try:
            self.packets.save_done(self._done)
        except StoreFull:  # its room is kept; a store that still says no costs only the memory
            self.stats["store_full"] += 1

    def _sack(self, now, link, src, seg, tries=0):
        # seg: (head, bytes) from acomm.transport.segment
        if self._quiet and not tries:
            return
        rid = self.node.next_req_id()
        if link.request(now, rid, self.node.names.name_of(src), seg[1], 60, _SACK_PRIORITY, False, None, SEGMENT,
                        seg[0]):
            self._sacks[rid] = (link, src, seg, tries)

    def _sack_status(self, now, rid, status):
        # -> True when rid was one of our SACKs
        sk = self._sacks.get(rid)
        if sk is None:
            return False
        if status >= _TRANSMITTED:
            del self._sacks[rid]
            # a modem that refused it (busy acknowledging the fragment it
            # just received) gets it again, twice at most
            if status == _FAILED and sk[3] < 2:
                self._sack(now, sk[0], sk[1], sk[2], sk[3] + 1)
        return True

