# Frame authentication with a per-network key: a truncated HMAC-SHA256 tag
# and a per-source counter against replays (docs/wire-format.md,
# "Authentication", has the layout, the costs and the key lifecycle).
#
# An authenticated frame has the F_AUTH flag and its payload ends with
#
#     counter (3 bytes, big-endian: key phase bit, then 23 bits)  tag
#
# tag = HMAC-SHA256(key, 0x02 type src dst seq epoch(4) counter payload)
# [:tag_len], with dst 255 for broadcast. When src or dst is a node id of
# 256 or more (acomm.frame.addr_bytes), both take 2 bytes, big-endian, and
# the first byte is 0x04 instead (0x05 for 0x03 below): never the input of
# another frame, so 300 is never taken for 44, the id it shares modulo 256.
# The addresses and the frame type
# are covered whether the link carries them in acomm's raw header or the
# modem carries them (elided form), so a tag heard towards one node is no
# good towards another. The sequence number is covered too: the link's
# duplicate filter goes by it, and a SEGMENT frame's lane, generation, poll
# and SACK bits ride in it (acomm.transport.segment). The flags are not.
#
# Exactly once: a link resends a request with the counter of its first copy
# (seal(..., again=counter)), so every copy is the same frame and the
# receiver's window takes at most one of them, however late. A genuine copy
# of a frame taken before that asks for an acknowledgement opens as
# (None, counter) when asked (open(..., again=True)) and its counter is in
# the window: the link acknowledges it again and hands nothing up.
#
# A sealed ACK carries no counter of its own: its tag (ack_tag) is bound to
# the counter of the frame it acknowledges, HMAC(key, 0x03 ACK src dst seq
# epoch counter), epoch and key phase those of that frame's sender.
#
# Replays: each sender numbers its frames 1, 2, ... (one counter for all
# its links and keys); a receiver keeps, per source, the highest counter it
# accepted and a 32-frame window below it, and refuses a counter it has
# seen or one older than the window. 2^23 - 1 frames per epoch.
#
# Two keys: the counter's top bit names the key (phase 0 or 1), so during
# a rotation a receiver holds both and a frame costs nothing more. The key
# given at start is phase 0. A sealed key command (key_command(), carried
# out by acomm.link.guard when it arrives sealed) installs a key derived
# from that base key and a nonce in a phase, switches the phase the node
# sends with, or drops a phase. A key delivered out of band goes in with
# add_key().
#
# Restarts: with `path`, the counters live in a small file, written
# without a flash write per frame: the sender reserves `reserve` counters
# at a time and writes only when it runs out (after a restart it resumes
# past the reservation); a receiver writes the sources' highest counters
# every `reserve` accepted frames, and at once (commit()) when the node
# accepts a command or its link hands up a sealed DATA or route control
# frame, so none of those can be replayed after a restart.
#
# Epochs: a node whose counter file is missing or damaged cannot know
# where its counter stood, and starting again from 1 would make every peer
# refuse its frames as replays. It starts a new epoch instead: the wall
# clock's seconds (wall(), at least 1 + the last one). Every tag covers the
# sender's epoch; its adverts, and its first ANNOUNCE_FRAMES frames that
# have room for it, carry the epoch in the clear (the trailer counter
# field is then 0 and the real counter and the epoch precede it),
# and a receiver takes a newer epoch from a source only from a frame that
# verifies under it, restarting that source's window there. An older epoch
# is refused, so a recording of an old announcement opens nothing.

import os

from ..errors import AcommError, AuthError
from ..codec.hmacsha256 import HmacKey, same

CTR_LEN = 3
EPOCH_LEN = 4
ANNOUNCE_EXTRA = 7  # an epoch announcement's bytes beyond the usual trailer
ANNOUNCE_FRAMES = 256  # the first frames of a new epoch that carry it, room permitting
_CTR_MAX = 0x7FFFFF
_PHASE = 0x800000
_WINDOW = 32
_MAGIC = b"AK2"
# the sources whose counters a node keeps: all the one-byte ids. A node that
# has heard this many (ids of 256 and more: a network of more than 254
# nodes) refuses a new one's sealed frames rather than forget a window
_MAX_SOURCES = 255
_NONCE_LEN = 8
# key commands: b"\xa5K", op, phase, then for install an 8-byte nonce
KEY_CMD = b"\xa5K"
OP_INSTALL = 1
OP_USE = 2
OP_DROP = 3


def key_command(op, phase, nonce=b""):
    """The payload of a key command (send it sealed, as DATA or a packet)."""
    if op not in (OP_INSTALL, OP_USE, OP_DROP) or phase not in (0, 1):
        raise AcommError("key command: op 1..3 and phase 0 or 1")
    if (op == OP_INSTALL) != (len(nonce) == _NONCE_LEN):
        raise AcommError("key command: install takes an 8-byte nonce, the others none")
    return KEY_CMD + bytes((op, phase)) + bytes(nonce)


def _check_key(key):
    if not isinstance(key, (bytes, bytearray)) or not 16 <= len(key) <= 64:
        raise AcommError("auth key: 16 to 64 bytes, not %s" % (
            "%d bytes" % len(key) if isinstance(key, (bytes, bytearray)) else type(key).__name__))


def _wall_default():
    import time

    return int(time.time())


def _b3(v):
    return bytes(((v >> 16) & 0xFF, (v >> 8) & 0xFF, v & 0xFF))


def _b4(v):
    return bytes(((v >> 24) & 0xFF, (v >> 16) & 0xFF, (v >> 8) & 0xFF, v & 0xFF))


def _u(b, o, n):
    v = 0
    for i in range(n):
        v = (v << 8) | b[o + i]
    return v


class Auth:
    def __init__(self, key, tag_len=4, path=None, reserve=64, wall=None):
        _check_key(key)
        if not 4 <= tag_len <= 16:
            raise AcommError("auth tag_len: 4 to 16 bytes, not %r" % (tag_len,))
        if not 1 <= reserve <= 65536:
            raise AcommError("auth reserve: 1 to 65536, not %r" % (reserve,))
        self._base = HmacKey(key)
        self._keys = [self._base, None]
        self._nonces = [None, None]  # the nonce a phase's key was derived with
        self.phase = 0  # the key we send with
        self.tag_len = tag_len
        self.overhead = CTR_LEN + tag_len
        self.path = path
        self.reserve = reserve
        self.wall = wall or _wall_default
        self.epoch = 0
        self._ann_end = 0  # frames up to this counter carry the epoch when they have room
        self._next = 1  # the next counter to send
        self.last = 0  # the counter (and phase bit) of the latest seal
        self._reserved = 0  # counters up to this one are on file as used
        self._rx = {}  # source id -> [highest accepted, window bitmap, epoch]
        self._rx_saved = 0  # frames accepted since the file was written
        self.stats = {"sealed": 0, "opened": 0, "bad_tag": 0, "replayed": 0, "saves": 0, "epochs": 0,
                      "no_key": 0, "again": 0}
        if path is not None:
            self._load()

    # -- keys --------------------------------------------------------------------
    def add_key(self, key, phase):
        """A key delivered out of band, accepted (and usable) as `phase`."""
        _check_key(key)
        if phase not in (0, 1):
            raise AcommError("auth key phase: 0 or 1")
        self._keys[phase] = HmacKey(key)
        self._nonces[phase] = None

    def key_command(self, payload):
        """Carries out a key command (it arrived sealed: the caller checked);
        -> True when the payload was one."""
        if len(payload) < 4 or payload[:2] != KEY_CMD:
            return False
        op, phase = payload[2], payload[3]
        if phase > 1:
            return True
        if op == OP_INSTALL and len(payload) == 4 + _NONCE_LEN:
            nonce = bytes(payload[4:])
            if phase != self.phase:  # never the key in use
                self._keys[phase] = HmacKey(self._base.digest(b"acomm key", nonce))
                self._nonces[phase] = nonce
        elif op == OP_USE and self._keys[phase] is not None:
            self.phase = phase
        elif op == OP_DROP and phase != self.phase:
            self._keys[phase] = None
            self._nonces[phase] = None
        self._save()
        return True

    # -- sending ---------------------------------------------------------------
    def announcing(self):
        # whether a frame with room for it should carry the epoch now
        return self.epoch != 0 and self._next <= self._ann_end

    def seal(self, ftype, src, dst, payload, seq=0, announce=False, again=0):
        # -> payload + counter + tag; announce: the epoch rides along in the
        # clear (adverts: how peers learn a new epoch). again: a counter this
        # node sealed with before (self.last after that seal): a resent
        # request keeps its counter, so every copy of it is the same frame
        # and the receiver's window takes at most one, however late
        p = 1 if again & _PHASE else 0
        c = again & _CTR_MAX
        if not c or c >= self._next or self._keys[p] is None:
            # a fresh count (or the phase of the first copy was dropped meanwhile)
            p = self.phase
            c = self._next
            if c > _CTR_MAX:
                raise AcommError("auth counter exhausted: the network needs a new key")
            if c > self._reserved:
                self._reserved = min(c + self.reserve - 1, _CTR_MAX)
                self._save()
            self._next = c + 1
            self.stats["sealed"] += 1
        key = self._keys[p]
        if key is None:  # an add_key() key the port has not added again since the start
            raise AcommError("auth: no key for phase %d, the one in use" % p)
        self.last = c | (_PHASE if p else 0)
        ctr = _b3(self.last)
        ep = _b4(self.epoch)
        tag = self._tag(key, ftype, src, dst, seq, ep, ctr, payload)
        if announce and self.epoch:
            return bytes(payload) + ctr + ep + (b"\x80\x00\x00" if p else b"\x00\x00\x00") + tag
        return bytes(payload) + ctr + tag

    # -- receiving -------------------------------------------------------------
    def open(self, ftype, src, dst, body, seq=0, again=False):
        # -> (payload, counter and its phase bit); AuthError when the tag is wrong or the
        # counter was seen. Nothing is recorded until the tag verifies.
        # again: the frame asks for an acknowledgement, so a genuine copy of
        # one accepted before, whose counter is still inside the window, gives
        # (None, counter): acknowledge it again (our ack may be what was
        # lost), never deliver it again. Older copies get nothing.
        n = len(body) - self.overhead
        if n < 0:
            self.stats["bad_tag"] += 1
            raise AuthError("authenticated frame shorter than its counter and tag")
        mv = memoryview(body)
        ctr = mv[n : n + CTR_LEN]
        key = self._keys[1 if ctr[0] & 0x80 else 0]
        if key is None:
            self.stats["no_key"] += 1
            raise AuthError("frame sealed with a key phase this node does not hold")
        st = self._rx.get(src)
        if (ctr[0] & 0x7F) | ctr[1] | ctr[2]:
            ep = _b4(0 if st is None else st[2])
            tag = mv[n + CTR_LEN :]
        else:  # an epoch announcement: counter, epoch, then this marker
            n -= CTR_LEN + EPOCH_LEN
            if n < 0:
                self.stats["bad_tag"] += 1
                raise AuthError("epoch announcement shorter than its trailer")
            tag = mv[n + 2 * CTR_LEN + EPOCH_LEN :]
            ctr = mv[n : n + CTR_LEN]
            ep = mv[n + CTR_LEN : n + CTR_LEN + EPOCH_LEN]
        if not same(self._tag(key, ftype, src, dst, seq, ep, ctr, mv[:n]), tag):
            self.stats["bad_tag"] += 1
            raise AuthError("authentication tag does not verify")
        c = ((ctr[0] & 0x7F) << 16) | (ctr[1] << 8) | ctr[2]
        e = _u(ep, 0, EPOCH_LEN)
        if st is not None and e > st[2]:
            # a newer epoch, under a tag only the key makes: the source lost
            # its counters and starts again; written at once
            st[0], st[1], st[2] = c, 1, e
            self.stats["epochs"] += 1
            self._rx_saved += 1
            self.commit()
        elif (st is not None and e < st[2]) or not self._fresh(src, c, e):
            self.stats["replayed"] += 1
            if again and e == st[2] and 0 <= st[0] - c < _WINDOW:
                self.stats["again"] += 1
                return None, _u(ctr, 0, CTR_LEN)
            raise AuthError("counter %d of epoch %d from %d already seen" % (c, e, src))
        self.stats["opened"] += 1
        self._rx_saved += 1
        if self._rx_saved >= self.reserve:
            self._save()
        return bytes(mv[:n]), _u(ctr, 0, CTR_LEN)  # with the phase bit: what an ACK echoes

    def ack_tag(self, src, dst, seq, ctr, tag=None):
        # A sealed ACK (src acknowledges to dst the frame with header
        # sequence seq that dst sealed with counter ctr) carries no counter of
        # its own: its tag is bound to that counter, which no other frame of
        # dst's epoch has, so a recorded ACK acknowledges nothing but the
        # same frame again. -> the tag to send (epoch: dst's, as we hold it),
        # or with tag, whether it verifies (epoch: ours, dst is us)
        key = self._keys[1 if ctr & _PHASE else 0]
        if tag is None:
            st = self._rx.get(dst)
            e = 0 if st is None else st[2]
        else:
            e = self.epoch
        if key is None:
            self.stats["no_key"] += 1
            return None if tag is None else False
        if src > 255 or dst > 255:  # as _tag
            head = bytes((5, 1, src >> 8, src & 0xFF, dst >> 8, dst & 0xFF, seq & 0xFF))
        else:
            head = bytes((3, 1, src, dst, seq & 0xFF))
        t = key.digest(head, _b4(e), _b3(ctr))[: self.tag_len]
        if tag is None:
            return t
        if same(t, tag):
            self.stats["opened"] += 1
            return True
        self.stats["bad_tag"] += 1
        return False

    def commit(self):
        # the node accepted a command: its counter goes to the file now
        if self._rx_saved:
            self._save()

    def _fresh(self, src, c, e):
        st = self._rx.get(src)
        if st is None:
            if len(self._rx) >= _MAX_SOURCES:
                return False  # only with ids of 256 and more (_MAX_SOURCES)
            self._rx[src] = [c, 1, e]
            return True
        hi, bits = st[0], st[1]
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

    def _tag(self, key, ftype, src, dst, seq, ep, ctr, payload):
        # one-byte ids as they always were; an id of 256 or more makes both
        # 2 bytes under another first byte (MicroPython's bytes() would keep
        # a wide id's low byte without a word: the id 44 shares with 300)
        d = 255 if dst is None else dst
        if src > 255 or d > 255:
            head = bytes((4, ftype & 0xFF, src >> 8, src & 0xFF, d >> 8, d & 0xFF, seq & 0xFF))
        else:
            head = bytes((2, ftype & 0xFF, src, d, seq & 0xFF))
        return key.digest(head, ep, ctr, payload)[: self.tag_len]

    # -- the counter file --------------------------------------------------------
    # "AK2", phase (1), epoch (4), reserved (3), then for each phase a flag
    # (0: as at start, the base key in phase 0 and an add_key() one in 1;
    # 1: derived, the 8-byte nonce follows; 2: dropped), then n (1) and n x
    # (source (1), epoch (4), highest (3)) for the one-byte sources; then,
    # only when there are sources of 256 and more, m (1) and m x (source (2),
    # epoch (4), highest (3)). Written to path + ".new" and renamed over
    # path, so a power cut leaves the old file or the new one.
    def _save(self):
        self._rx_saved = 0
        if self.path is None:
            return
        out = bytearray(_MAGIC)
        out.append(self.phase)
        out += _b4(self.epoch) + _b3(self._reserved)
        for p in (0, 1):
            if self._nonces[p] is not None:
                out.append(1)
                out += self._nonces[p]
            else:
                out.append(2 if self._keys[p] is None else 0)
        wide = [src for src in self._rx if src > 255]
        out.append(len(self._rx) - len(wide))
        for src in self._rx:
            if src < 256:
                st = self._rx[src]
                out.append(src)
                out += _b4(st[2]) + _b3(st[0])
        if wide:
            out.append(len(wide))
            for src in wide:
                st = self._rx[src]
                out += bytes((src >> 8, src & 0xFF)) + _b4(st[2]) + _b3(st[0])
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
                    data = f.read(17 + 2 * _NONCE_LEN + 9 * _MAX_SOURCES)
                break
            except OSError:
                continue
        if data is None or not self._parse(data):
            # lost or damaged: where our counter stood is unknown, so a new
            # epoch; the peers' counters start over too (what they send
            # next is fresh to us; at most their last frames pass again,
            # which the layers above treat as duplicates)
            self._rx = {}
            self.phase = 0
            self._keys = [self._base, None]
            self._nonces = [None, None]
            self.epoch = max(int(self.wall()), self.epoch + 1, 1)
            self._ann_end = ANNOUNCE_FRAMES
            self._next = 1
            self._reserved = 0
            self.stats["epochs"] += 1
            self._save()

    def _parse(self, data):
        # -> False when the file is not a whole counter file
        n = len(data)
        if n < 14 or data[:3] != _MAGIC or data[3] > 1:
            return False
        o = 11
        nonces = [None, None]
        dropped = [False, False]
        for p in (0, 1):
            if data[o] == 1 and o + 1 + _NONCE_LEN <= n:
                nonces[p] = bytes(data[o + 1 : o + 1 + _NONCE_LEN])
                o += 1 + _NONCE_LEN
            elif data[o] <= 2:
                dropped[p] = data[o] == 2
                o += 1
            else:
                return False
            if o >= n:
                return False
        count = data[o]
        o += 1
        w = o + 8 * count  # where the section of sources of 256 and more starts, if any
        m = 0
        if n < w:
            return False  # not whole
        if n > w:  # that section: m (never 0), then m entries
            m = data[w]
            if not m or n != w + 1 + 9 * m:
                return False  # not whole
        if dropped[data[3]]:
            return False  # the phase in use dropped
        self.phase = data[3]
        self.epoch = _u(data, 4, 4)
        self._reserved = _u(data, 8, 3)
        self._next = self._reserved + 1
        for p in (0, 1):
            self._nonces[p] = nonces[p]
            if nonces[p] is not None:
                self._keys[p] = HmacKey(self._base.digest(b"acomm key", nonces[p]))
            elif dropped[p]:
                self._keys[p] = None
        for i in range(count):
            k = o + 8 * i
            self._rx[data[k]] = [_u(data, k + 5, 3), 0xFFFFFFFF, _u(data, k + 1, 4)]
        for i in range(m):
            k = w + 1 + 9 * i
            self._rx[_u(data, k, 2)] = [_u(data, k + 6, 3), 0xFFFFFFFF, _u(data, k + 2, 4)]
        return True
