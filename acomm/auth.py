# Frame authentication with a per-network key: a truncated HMAC-SHA256 tag
# and a per-source counter against replays.
#
# An authenticated frame has the F_AUTH flag and its payload ends with
#
#     counter (3 bytes, big-endian)  tag (tag_len bytes, 4 by default)
#
# tag = HMAC-SHA256(key, 0x02 type src dst seq counter payload)[:tag_len],
# with dst 255 for broadcast. The addresses and the frame type are covered
# whether the link carries them in acomm's raw header or the modem carries
# them (elided form), so a tag heard towards one node is no good towards
# another. The sequence number is covered too: the link's duplicate filter
# goes by it, and a SEGMENT frame's lane, generation, poll and SACK bits
# ride in it (acomm.segment), so a frame heard cannot be given another one.
# The flags are not: a link resends a frame sealed afresh anyway.
#
# Replays: each sender numbers its frames 1, 2, ... (one counter for all
# its links); a receiver keeps, per source, the highest counter it accepted
# and a 32-frame window below it, and refuses a counter it has seen or one
# older than the window. 2^24 - 1 frames per key: then the sender refuses
# to send authenticated frames until it is given a new key.
#
# Restarts: with `path`, the counters live in a small file, written
# without a flash write per frame: the sender reserves `reserve` counters
# at a time and writes only when it runs out (after a restart it resumes
# past the reservation, skipping at most `reserve` numbers); a receiver
# writes the sources' highest counters every `reserve` accepted frames, and
# at once when the node accepts a command (commit()), so no command can be
# replayed after a restart. What a restart can let through is a replay of
# one of the last `reserve` ordinary frames, which the layers above treat
# as a duplicate.

import os

from .errors import AcommError, AuthError
from .hmacsha256 import HmacKey, same

CTR_LEN = 3
_CTR_MAX = 0xFFFFFF
_WINDOW = 32
_MAGIC = b"AK1"
_MAX_SOURCES = 255  # one per node id


class Auth:
    def __init__(self, key, tag_len=4, path=None, reserve=64):
        if not isinstance(key, (bytes, bytearray)) or not 16 <= len(key) <= 64:
            raise AcommError("auth key: 16 to 64 bytes, not %s" % (
                "%d bytes" % len(key) if isinstance(key, (bytes, bytearray)) else type(key).__name__))
        if not 4 <= tag_len <= 16:
            raise AcommError("auth tag_len: 4 to 16 bytes, not %r" % (tag_len,))
        if not 1 <= reserve <= 65536:
            raise AcommError("auth reserve: 1 to 65536, not %r" % (reserve,))
        self._key = HmacKey(key)
        self.tag_len = tag_len
        self.overhead = CTR_LEN + tag_len
        self.path = path
        self.reserve = reserve
        self._next = 1  # the next counter to send
        self._reserved = 0  # counters up to this one are on file as used
        self._rx = {}  # source id -> [highest accepted, window bitmap]
        self._rx_saved = 0  # frames accepted since the file was written
        self.stats = {"sealed": 0, "opened": 0, "bad_tag": 0, "replayed": 0, "saves": 0}
        if path is not None:
            self._load()

    # -- sending ---------------------------------------------------------------
    def seal(self, ftype, src, dst, payload, seq=0):
        # -> payload + counter + tag
        c = self._next
        if c > _CTR_MAX:
            raise AcommError("auth counter exhausted: the network needs a new key")
        if c > self._reserved:
            self._reserved = min(c + self.reserve - 1, _CTR_MAX)
            self._save()
        self._next = c + 1
        ctr = bytes(((c >> 16) & 0xFF, (c >> 8) & 0xFF, c & 0xFF))
        tag = self._tag(ftype, src, dst, seq, ctr, payload)
        self.stats["sealed"] += 1
        return bytes(payload) + ctr + tag

    # -- receiving -------------------------------------------------------------
    def open(self, ftype, src, dst, body, seq=0):
        # -> (payload, counter); AuthError when the tag is wrong or the
        # counter was seen. Nothing is recorded until the tag verifies.
        n = len(body) - self.overhead
        if n < 0:
            self.stats["bad_tag"] += 1
            raise AuthError("authenticated frame shorter than its counter and tag")
        mv = memoryview(body)
        ctr = mv[n : n + CTR_LEN]
        if not same(self._tag(ftype, src, dst, seq, ctr, mv[:n]), mv[n + CTR_LEN :]):
            self.stats["bad_tag"] += 1
            raise AuthError("authentication tag does not verify")
        c = (ctr[0] << 16) | (ctr[1] << 8) | ctr[2]
        if not self._fresh(src, c):
            self.stats["replayed"] += 1
            raise AuthError("counter %d from %d already seen" % (c, src))
        self.stats["opened"] += 1
        self._rx_saved += 1
        if self._rx_saved >= self.reserve:
            self._save()
        return bytes(mv[:n]), c

    def commit(self):
        # the node accepted a command: its counter goes to the file now
        if self._rx_saved:
            self._save()

    def _fresh(self, src, c):
        st = self._rx.get(src)
        if st is None:
            if len(self._rx) >= _MAX_SOURCES:
                return False  # cannot happen with node ids 0..254
            self._rx[src] = [c, 1]
            return True
        hi, bits = st
        if c > hi:
            shift = c - hi
            st[1] = ((bits << shift) | 1) & 0xFFFFFFFF if shift < _WINDOW else 1
            st[0] = c
            return True
        back = hi - c
        if back >= _WINDOW or bits & (1 << back):
            return False
        st[1] = bits | (1 << back)
        return True

    def _tag(self, ftype, src, dst, seq, ctr, payload):
        head = bytes((2, ftype & 0xFF, src & 0xFF, 255 if dst is None else dst & 0xFF, seq & 0xFF))
        return self._key.digest(head, ctr, payload)[: self.tag_len]

    # -- the counter file --------------------------------------------------------
    # "AK1", reserved (3), n (1), then n x (source (1), highest (3)); written
    # to path + ".new" and renamed over path, so a power cut leaves the old
    # file or the new one, never half of one.
    def _save(self):
        self._rx_saved = 0
        if self.path is None:
            return
        out = bytearray(_MAGIC)
        r = self._reserved
        out += bytes(((r >> 16) & 0xFF, (r >> 8) & 0xFF, r & 0xFF, len(self._rx)))
        for src in self._rx:
            h = self._rx[src][0]
            out += bytes((src & 0xFF, (h >> 16) & 0xFF, (h >> 8) & 0xFF, h & 0xFF))
        tmp = self.path + ".new"
        with open(tmp, "wb") as f:
            f.write(out)
        try:
            os.remove(self.path)  # MicroPython's rename does not replace
        except OSError:
            pass
        os.rename(tmp, self.path)
        self.stats["saves"] += 1

    def _load(self):
        data = None
        for p in (self.path, self.path + ".new"):
            try:
                with open(p, "rb") as f:
                    data = f.read(8 + 4 * _MAX_SOURCES)
                break
            except OSError:
                continue
        if data is None:
            return  # a new node: counters start at 1
        if len(data) < 7 or data[:3] != _MAGIC or len(data) != 7 + 4 * data[6]:
            # starting from 1 would make every peer refuse our frames as
            # replays, and forgetting theirs would accept old ones
            raise AcommError("auth counter file %s is damaged; remove it only together with a new key" % self.path)
        self._reserved = (data[3] << 16) | (data[4] << 8) | data[5]
        self._next = self._reserved + 1
        for i in range(data[6]):
            o = 7 + 4 * i
            self._rx[data[o]] = [(data[o + 1] << 16) | (data[o + 2] << 8) | data[o + 3], 0xFFFFFFFF]
