# The transport's packets in a store (acomm.transport.store.Store on a file, or
# acomm.transport.memorystore.MemoryStore in RAM), and the store's overflow rule.
#
# A packet is one or more records. Chunk 0 holds the header and the start
# of the body; chunks 1..n-1 the rest, each at most the store's max_record.
# Key of chunk i: i << 24 | origin << 16 | pid; for an origin of 256 or more
# (which does not fit the key), i << 24 | 0xFF << 16 | a slot that put()
# finds free (no one-byte origin is 255). put() writes chunks 1..n-1
# first and chunk 0 last, delete() removes chunk 0 first: a packet exists
# exactly when its chunk 0 does, and recovery deletes chunks left without
# one (a cut in the middle of a put or a delete).
#
# Chunk 0 header, 11 bytes: origin, final destination (node ids, 3 bytes
# each from 256 up, as acomm.frame.addr_bytes writes them), pid (2, big-endian),
# priority, flags (bit 0: body compressed; bit 1: a medium name follows),
# expiry (4, wall-clock seconds, big-endian), chunk count; then the medium
# (a length byte and the name) when flagged; then body bytes.
#
# One more record, key 0xFFFFFF (origin 255 is the broadcast address, never
# a sender), holds the packet id limit: ids below it may have been used.
# It is written once per _PID_BLOCK packets, so a restarted sender never
# reuses an id a receiver may still remember (duplicate suppression keys on
# origin and id), without a write per packet.
#
# Another, key 0xFFFFFE, holds the receiver's last DONE_MEMORY delivered
# (origin, pid) pairs, 3 bytes each, rewritten at every delivery: a
# receiver that lost power between delivering a packet and its sender
# hearing the SACK would otherwise deliver the resent packet a second time.
# 0xFFFFFD holds them with the minute their copies stop (5 bytes each), and
# 0xFFFFFC those from origins of 256 or more (7 bytes: the origin in 3).
#
# Overflow rule: a store with a capacity keeps its last quarter for urgent
# packets (priority <= urgent). A packet that does not fit is refused when
# it is offered (send() reports `failed`; a relay answers "receiver full"
# and the sender keeps the packet and tries again later). A packet once
# accepted is never dropped to make room: it leaves when delivered or
# expired.

from ..compat import const
from .. import errors  # one name in this module's dict, not two (the buoy's heap)
from ..frame import get_addr

_HDR = const(11)
_META = const(0xFFFFFF)
_DONE = const(0xFFFFFE)  # before 5-byte entries: (origin, pid) only, read once and converted
_DONE5 = const(0xFFFFFD)
_DONE7 = const(0xFFFFFC)
_WIDE_KEYS = const(0xFF0000)  # chunk 0 keys of packets from origins of 256 or more: slots 0..0xFFFB
DONE_MEMORY = const(32)
_PID_BLOCK = const(32)
_REC_OVERHEAD = const(12)  # acomm.transport.store's record header and CRC
_F_COMPRESSED = const(1)
_F_MEDIUM = const(2)
# Room kept free for the id-limit record: a store rewrites it while the old
# copy is still live, so two copies must fit. Without it a full store could
# not move the limit and no new packet id could be handed out safely.
# The same for the delivered pairs (at their most), so that a full store
# still remembers what it delivered.
_META_ROOM = const(2 * (_REC_OVERHEAD + 2) + 2 * (_REC_OVERHEAD + 5 * DONE_MEMORY))


def key_of(p):
    """The key of chunk 0 of packet p in the store: its origin and pid, or for an origin of
    256 or more the slot put() found (p.key)."""
    return (p.origin << 16) | p.pid if p.origin < 255 else p.key


class Stored:
    # what recover() gives back for each packet
    # body is None: the transport reads it back (blob()) when it sends the packet
    # at: where the body starts in chunk 0
    # fields: origin, final, pid, prio, expiry, compressed, medium, body, chunks, size, key, at
    pass


class StoredBlob:
    # A packet as its transfer sends it, a packet header (head) and then the
    # body, with the body left in the store: read() reads back only the
    # records that hold the bytes asked for. A buoy sending a 1 KiB packet
    # then holds a record or two at a time, not the body joined from its
    # records and copied again behind the header: three allocations of the
    # packet's size, its largest, made when its heap is fragmented.
    # fields: head, store, key, at, chunk, size

    def __len__(self):
        return len(self.head) + self.size

    def read(self, off, n):
        """Bytes off..off+n of head + body (fewer past the end); None when a record is gone or shorter than it was."""
        head = self.head
        out = b""
        if off < len(head):
            out = head[off : off + n]
            n -= len(out)
            off = 0
        else:
            off -= len(head)
        end = off + n
        if end > self.size:
            end = self.size
        first = self.chunk - self.at  # body bytes in chunk 0 (put() fills it)
        while off < end:
            if off < first:
                i, a = 0, self.at + off
                take = (end if end < first else first) - off
            else:
                i = 1 + (off - first) // self.chunk
                a = (off - first) % self.chunk
                take = self.chunk - a
                if take > end - off:
                    take = end - off
            try:
                rec = self.store.get((i << 24) | self.key)
            except errors.StoreError:  # unreadable now (an I/O error): as if gone
                return None
            if rec is None or len(rec) < a + take:
                return None
            out += rec[a : a + take]
            off += take
        return out


class PacketStore:
    def __init__(self, store, urgent=4):
        self.store = store
        self.urgent = urgent
        self.chunk = min(getattr(store, "max_record", 65535), 65535)
        self.pid = 0
        self._limit = 0  # ids up to here are covered by the stored limit
        self.done = b""  # what recover() found: 5 bytes an entry (origin, pid, until minute), see save_done
        self.done_wide = b""  # the same for origins of 256 or more, 7 bytes an entry

    def _sizes(self, p):
        # p.size: the body's length (the body itself may be in the store only)
        n = _HDR + (1 + len(p.medium) if p.medium else 0) + p.size + (2 if p.origin > 254 else 0) + (2 if p.final > 254 else 0)
        return n, (n + self.chunk - 1) // self.chunk

    def room(self, p, urgent=None):
        # whether the overflow rule lets packet p in (urgent: the packet may
        # use the last quarter; default: by its priority)
        cap = getattr(self.store, "capacity_bytes", None)
        if cap is None:
            return True
        n, chunks = self._sizes(p)
        if urgent is None:
            urgent = p.prio <= self.urgent
        limit = (cap if urgent else cap - cap // 4) - _META_ROOM
        return self.store.live_bytes + n + chunks * _REC_OVERHEAD <= limit

    def next_pid(self):
        pid = (self.pid + 1) & 0xFFFF
        if ((pid - self._limit) & 0xFFFF) < 0x8000:
            # past the stored limit: move it a block ahead first
            limit = (pid + _PID_BLOCK) & 0xFFFF
            self.store.put(_META, bytes((limit >> 8, limit & 0xFF)))
            self._limit = limit
        self.pid = pid
        return pid

    def save_done(self, done, wide=None):
        # done: the packets done here, 5 bytes each (origin, pid high, pid
        # low, until minute high, low), at most DONE_MEMORY of them; wide:
        # those from origins of 256 or more, 7 bytes each (the origin in 3)
        self.store.put(_DONE5, bytes(done))  # the room for it is kept (_META_ROOM)
        if wide:
            self.store.put(_DONE7, bytes(wide))  # no room kept for it (_META_ROOM is sized for a board): a refusal costs the memory only

    def put(self, p):
        # raises StoreFull (nothing of the packet stays then)
        n, chunks = self._sizes(p)
        if chunks > 255:
            raise errors.StoreFull("packet of %d bytes needs more than 255 records" % p.size)
        if not self.room(p, True):
            raise errors.StoreFull("store full")
        p.chunks = chunks
        flags = (_F_COMPRESSED if p.compressed else 0) | (_F_MEDIUM if p.medium else 0)
        e = p.expiry & 0xFFFFFFFF
        head = bytes((p.pid >> 8, p.pid & 0xFF, p.prio, flags, e >> 24, (e >> 16) & 0xFF, (e >> 8) & 0xFF, e & 0xFF, chunks))
        if p.origin < 255 and p.final < 255:
            head = bytes((p.origin, p.final)) + head
        else:
            ids = bytearray()
            for a in (p.origin, p.final):
                ids.extend((a,) if a < 255 else (255, a >> 8, a & 0xFF))  # acomm.frame.addr_bytes
            head = bytes(ids) + head
            if p.origin > 254 and p.key is None:
                s = p.pid % 0xFFFC
                while self.store.length(_WIDE_KEYS | s) is not None:
                    s = (s + 1) % 0xFFFC
                p.key = _WIDE_KEYS | s
        if p.medium:
            m = p.medium.encode()
            head += bytes((len(m),)) + m
        first = self.chunk - len(head)
        body = p.body
        key = key_of(p)
        try:
            for i in range(1, chunks):
                a = first + (i - 1) * self.chunk
                self.store.put((i << 24) | key, body[a : a + self.chunk])
            self.store.put(key, head + body[:first])
        except errors.StoreError:  # full, or an I/O error: no chunk of it stays
            for i in range(1, chunks):
                self.store.delete((i << 24) | key)
            raise

    def delete(self, p):
        # p.chunks: what put() or recover() found (a copy of an "all"
        # packet has another medium than the record)
        key = key_of(p)
        self.store.delete(key)
        for i in range(1, p.chunks):
            self.store.delete((i << 24) | key)

    def body(self, key):
        """The stored body of the packet with this key, read back from the store; None when it is gone, damaged or unreadable."""
        try:
            s = self._load(key, True)
        except errors.StoreError:
            return None
        return None if s is None else s.body

    def blob(self, key, head):
        """The packet with this key as sent, head then its body, which stays in the store (StoredBlob); None when a record of it is gone or unreadable."""
        try:
            s = self._load(key, False)
        except errors.StoreError:
            return None
        if s is None:
            return None
        b = StoredBlob()
        b.head, b.store, b.key, b.at, b.size, b.chunk = head, self.store, key, s.at, s.size, self.chunk
        return b

    def recover(self):
        # -> [Stored] without their bodies (a board's heap holds only what
        # it is sending); drops what a cut left incomplete
        st = self.store
        keys = st.keys()
        heads = {}
        for k in keys:
            if k == _META:
                m = st.get(k)
                if m is not None and len(m) == 2:
                    self._limit = self.pid = (m[0] << 8) | m[1]
            elif k == _DONE5:
                m = st.get(k) or b""
                self.done = m[: len(m) - len(m) % 5]
            elif k == _DONE7:
                m = st.get(k) or b""
                self.done_wide = m[: len(m) - len(m) % 7]
            elif k == _DONE:
                # an older acomm's pairs: kept, with "until" left for the
                # transport to fill in (0xFFFF, then the minute it starts)
                m = st.get(k) or b""
                if not self.done:
                    self.done = b"".join(m[i : i + 3] + b"\xff\xff" for i in range(0, len(m) - 2, 3))
                st.delete(k)
            elif k >> 24 == 0:
                heads[k] = True
        out = []
        for k in keys:
            if k == _DONE or k == _DONE5 or k == _DONE7:
                continue
            if k == _META or k >> 24:
                if k != _META and (k & 0xFFFFFF) not in heads:
                    st.delete(k)  # a chunk whose packet is gone or never finished
                continue
            s = self._load(k, False)
            if s is None:
                self._drop(k)
            else:
                out.append(s)
        return out

    def _load(self, k, with_body):
        # with_body False: the header, and the body's size from the records'
        # lengths (every chunk must be there), without reading the chunks
        rec = self.store.get(k)
        if rec is None or len(rec) < _HDR:
            return None
        s = Stored()
        s.key = k
        if rec[0] != 255 and rec[1] != 255:
            s.origin, s.final, at = rec[0], rec[1], 2
        else:
            try:
                s.origin, at = get_addr(rec, 0)
                s.final, at = get_addr(rec, at)
            except errors.DecodeError:
                return None
        if len(rec) < at + 9:
            return None
        s.pid, s.prio, flags = (rec[at] << 8) | rec[at + 1], rec[at + 2], rec[at + 3]
        s.compressed = bool(flags & _F_COMPRESSED)
        s.expiry = int.from_bytes(rec[at + 4 : at + 8], "big")
        s.chunks = chunks = rec[at + 8]
        at += 9
        s.medium = None
        if flags & _F_MEDIUM:
            if at >= len(rec) or at + 1 + rec[at] > len(rec):
                return None
            try:
                s.medium = rec[at + 1 : at + 1 + rec[at]].decode()
            except ValueError:  # UnicodeError on CPython
                return None
            at += 1 + rec[at]
        s.at = at
        s.size = len(rec) - at
        s.body = None
        parts = [rec[at:]] if with_body else None
        for i in range(1, chunks):
            ck = (i << 24) | k
            if with_body:
                c = self.store.get(ck)
                n = None if c is None else len(c)
            else:
                n = self.store.length(ck)
            if n is None:
                return None
            s.size += n
            if with_body:
                parts.append(c)
        if with_body:
            s.body = b"".join(parts)
        return s

    def _drop(self, k):
        self.store.delete(k)
        for i in range(1, 256):
            kk = (i << 24) | k
            if self.store.get(kk) is None:
                break
            self.store.delete(kk)
