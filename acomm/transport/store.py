# acomm.transport.store: the persistent store under the store-and-forward transport.
#
# A packet is written here before send() returns and stays until it is
# delivered or expires, across resets and power cuts. Interface:
#
#   s = Store(path, capacity_bytes=65536, max_record=1024, sync=True, opener=None)
#       opens or creates the store at `path` and recovers it (below).
#       opener(path, mode) opens its files (default: the builtin open; the
#       tests give one that fills up or refuses). A path that cannot be
#       written fails here with one line naming it and the cause, e.g.
#       StoreError("store /x: read-only file system"), "permission denied";
#       StoreFull when the filesystem has no room to create the store.
#   s.put(key, data)   key: int 0..0xFFFFFFFF, data: bytes of at most
#                      max_record (<= 65535). Appended, flushed and synced
#                      before it returns; replaces an earlier record with the
#                      same key. Raises StoreFull when it would exceed
#                      capacity_bytes even after compaction, EncodeError for
#                      a bad key or an over-long record.
#                      A filesystem too full for the record (ENOSPC, or a
#                      short write: FAT says so without an error) is
#                      StoreFull too: the caller refuses what it cannot keep,
#                      and a put() once there is room again works. Any other
#                      failed write (EIO, a file system remounted read-only)
#                      is a StoreError naming the store and the cause. After
#                      a failed write the record is not in the store, then or
#                      after a reopen (the file is cut back where it was).
#   s.delete(key)      appends a tombstone; an unknown key is ignored. On a
#                      filesystem too full for the tombstone the record
#                      leaves the index at once and the file at the next
#                      compaction that fits (counted in delete_deferred):
#                      a reset before then brings it back. The same for any
#                      other failed write: delete() never raises for one.
#   s.get(key)         -> bytes, or None (unknown, or found corrupt on read:
#                      then it is dropped and counted in corrupt_dropped).
#   s.keys()           -> live keys in the order of their last put(), which
#                      is file order and survives reopen and compaction.
#   len(s), key in s
#   s.used_bytes       file size, header and dead records included; this is
#                      what capacity_bytes bounds. Also live_bytes, dead_bytes.
#   s.capacity_bytes, s.stats: dict of appends, deletes, compactions,
#                      torn_dropped, corrupt_dropped.
#   s.compact()        rewrites the live records to path + ".tmp", syncs it
#                      and renames it over the store. Done by itself when dead
#                      bytes pass half the file (and 256 bytes); one that does
#                      not fit leaves the store as it was (StoreFull when
#                      called, skipped when done by itself).
#   s.close()          (also a context manager)
#
# sync=True (CPython) fsyncs each record, the temporary file of a compaction
# and the directory after its rename; sync=False only flushes to the OS:
# safe against a killed process, not a power cut. On MicroPython flush()
# itself commits (lfs/FAT sync; fsync on the unix port), and sync=True adds
# os.sync() where the port has it.
#
# The file is a 4-byte header and an append-only log of checksummed records
# (byte layout in docs/wire-format.md, "Store records"). RAM holds only an
# index, 10 bytes per live record in two bytearrays (key; offset + length),
# so a board with a few KiB free can keep hundreds of KiB of packets; get()
# reads the file and checks the CRC again.
#
# Recovery at open: a leftover .tmp is removed when the store file exists
# (the rename never happened, so the store file is the truth) and renamed to
# it when the store file is missing (a FAT rename that deletes the target
# first was cut). Records are then read in order. A record that does not
# check is skipped up to the next offset where a whole record checks (found
# by its sync byte): that span was corrupted in place and is counted in
# corrupt_dropped. When no good record follows, the rest is a torn append,
# counted in torn_dropped and cut off (f.truncate, or a compaction where the
# port has no truncate) so the next append starts at a good boundary.
# A put() that returned was flushed whole, so recovery never loses it; a
# record only enters the index when its CRC-32 checks, so no corrupt data
# is ever returned. Limits: a corrupted tombstone brings its key back, and
# a corrupted replacement brings the older version back.
#
# Peak disk use is capacity_bytes + live bytes, while a compaction writes
# the temporary file next to the store.

import os
import struct

from ..compat import const
from ..codec.crc32 import crc32
from ..errors import EncodeError, StoreError, StoreFull

MAGIC = b"ACS\x01"  # "acomm store", format 1
_PUT = const(0x50)  # 'P'
_DEL = const(0x44)  # 'D'
_MAX_DATA = const(0xFFFF)
_SYNC = const(0xA5)
_SYNC_B = b"\xa5"
_HDR = const(8)  # sync, kind, key u32, length u16
_OVER = const(12)  # header + CRC-32
_MIN_DEAD = const(256)  # below this, compacting costs more than it frees
_CHUNK = const(128)  # read buffer for recovery and compaction
# errnos (Linux, MicroPython's littlefs and FAT; MicroPython's errno
# module has no ENOSPC or EROFS)
_ENOSPC = const(28)  # the filesystem is full
_EROFS = const(30)  # read-only file system
_EACCES = const(13)  # permission denied

_fsync = getattr(os, "fsync", None)  # CPython
_ossync = getattr(os, "sync", None)  # some MicroPython ports
_osopen = getattr(os, "open", None)
_replace = getattr(os, "replace", None) or os.rename


def _exists(p):
    try:
        os.stat(p)
        return True
    except OSError:
        return False


def _sync_dir(path):
    # A rename or a new file is durable only once its directory is: fsync
    # the directory where the OS allows it (CPython on POSIX). MicroPython
    # file systems commit directory changes themselves.
    if _osopen is None or _fsync is None:
        return
    i = path.rfind("/")
    d = path[:i] if i > 0 else ("/" if i == 0 else ".")
    try:
        fd = _osopen(d, getattr(os, "O_RDONLY", 0))
    except OSError:
        return
    try:
        _fsync(fd)
    except OSError:
        pass
    os.close(fd)


class Store:
    def __init__(self, path, capacity_bytes=65536, max_record=1024, sync=True, opener=None):
        if not 0 < max_record <= _MAX_DATA:
            raise StoreError("max_record must be 1..65535")
        if capacity_bytes < len(MAGIC) + _OVER:
            raise StoreError("capacity_bytes too small")
        self.path = path
        self._tmp = path + ".tmp"
        self.capacity_bytes = capacity_bytes
        self.max_record = max_record
        self._sync = sync
        self.stats = {"appends": 0, "deletes": 0, "compactions": 0, "torn_dropped": 0, "corrupt_dropped": 0,
                      "delete_deferred": 0}
        self._keys = bytearray()  # u32 LE per live record, in file order
        self._locs = bytearray()  # offset u32 + data length u16 per record
        self._buf = bytearray(_CHUNK)
        self._mv = memoryview(self._buf)
        self.used_bytes = self.live_bytes = self.dead_bytes = 0
        self._f = None
        self._open = opener or open
        try:
            if _exists(self._tmp):
                if _exists(path):
                    os.remove(self._tmp)
                else:
                    _replace(self._tmp, path)
            if not _exists(path):
                self._create()
            self._f = self._open(path, "r+b")
            self._recover()
        except OSError as e:
            # one line for the user: which store and why, not a traceback
            self.close()
            raise self._err(e)

    # -- the interface ---------------------------------------------------

    def put(self, key, data):
        self._file()
        if not 0 <= key <= 0xFFFFFFFF:
            raise EncodeError("store key out of range")
        n = len(data)
        if n > self.max_record:
            raise EncodeError("record longer than max_record")
        need = _OVER + n
        if self.used_bytes + need > self.capacity_bytes:
            # An older record with this key stays in the compacted file: it
            # must survive a cut before the new one is complete.
            if self.dead_bytes:
                self._compact_if_room()
            if self.used_bytes + need > self.capacity_bytes:
                raise StoreFull("store full")
        hdr = struct.pack("<BBIH", _SYNC, _PUT, key, n)
        off = self.used_bytes
        try:
            self._append_record(hdr, data, crc32(data, crc32(hdr)))
        except OSError as e:
            # the capacity fits but the filesystem does not (other files,
            # a small flash): a refusal, as above, never a crash. Nothing
            # moved: the next record goes where this one was
            self._reopen()
            raise self._err(e)
        j = self._find(key)
        if j >= 0:
            self._drop(j)
        self._keys.extend(hdr[2:6])
        self._locs.extend(struct.pack("<IH", off, n))
        self.live_bytes += need
        self.stats["appends"] += 1
        self._maybe_compact()

    def delete(self, key):
        self._file()
        j = self._find(key)
        if j < 0:
            return
        if self.used_bytes + _OVER > self.capacity_bytes:
            # No room for a tombstone: rewrite the file without the record.
            # A cut leaves the old file or the new one, either is right.
            self._drop(j)
            if not self._compact_if_room():
                self.stats["delete_deferred"] += 1
        else:
            hdr = struct.pack("<BBIH", _SYNC, _DEL, key, 0)
            try:
                self._append_record(hdr, b"", crc32(hdr))
            except OSError:
                # no room for the tombstone on the filesystem (or no write
                # at all): forgotten now, gone from the file at the next
                # compaction that fits
                self._reopen()
                self._drop(j)
                self.stats["delete_deferred"] += 1
                return
            self._drop(j)
            self.dead_bytes += _OVER
        self.stats["deletes"] += 1
        self._maybe_compact()

    def get(self, key):
        f = self._file()
        j = self._find(key)
        if j < 0:
            return None
        off, n = struct.unpack_from("<IH", self._locs, 6 * j)
        try:
            f.seek(off)
            hdr = f.read(_HDR)
            data = f.read(n)
            tail = f.read(4)
        except OSError as e:
            raise self._err(e)
        # The file may have rotted since it was opened: check again.
        if (
            len(tail) != 4
            or hdr != struct.pack("<BBIH", _SYNC, _PUT, key, n)
            or struct.unpack("<I", tail)[0] != crc32(data, crc32(hdr))
        ):
            self._drop(j)
            self.stats["corrupt_dropped"] += 1
            return None
        return data

    def keys(self):
        ks = self._keys
        return [struct.unpack_from("<I", ks, i)[0] for i in range(0, len(ks), 4)]

    def __len__(self):
        return len(self._keys) >> 2

    def __contains__(self, key):
        return self._find(key) >= 0

    def length(self, key):
        """The data length of the record with this key, or None; reads nothing from the file."""
        j = self._find(key)
        return None if j < 0 else struct.unpack_from("<IH", self._locs, 6 * j)[1]

    def compact(self):
        f = self._file()
        try:
            g = self._open(self._tmp, "wb")
            try:
                g.write(MAGIC)
                pos = len(MAGIC)
                keys = bytearray()
                locs = bytearray()
                ks = self._keys
                for j in range(len(ks) >> 2):
                    off, n = struct.unpack_from("<IH", self._locs, 6 * j)
                    # verify before copying so a record that rotted is left out
                    # instead of being carried into the new file
                    r = self._parse(off, self.used_bytes)
                    if r is None or r[0] != _PUT or r[2] != n or ks[4 * j : 4 * j + 4] != struct.pack("<I", r[1]):
                        self.stats["corrupt_dropped"] += 1
                        continue
                    self._copy(off, _OVER + n, g)
                    keys.extend(ks[4 * j : 4 * j + 4])
                    locs.extend(struct.pack("<IH", pos, n))
                    pos += _OVER + n
                self._flush(g)
                if g.tell() != pos:
                    raise OSError(_ENOSPC)  # a short write: FAT says so without an error
            finally:
                g.close()
            f.close()
            self._f = None
            _replace(self._tmp, self.path)
        except OSError as e:
            # the old file is still the store (a rename needs room on some
            # file systems too); the copy would only take room until the
            # next open
            try:
                os.remove(self._tmp)
            except OSError:
                pass
            if self._f is None:
                self._reopen()
            raise self._err(e)
        if self._sync:
            _sync_dir(self.path)
        self._keys = keys
        self._locs = locs
        self.used_bytes = pos
        self.live_bytes = pos - len(MAGIC)
        self.dead_bytes = 0
        self.stats["compactions"] += 1
        self._reopen()

    def close(self):
        if self._f is not None:
            self._f.close()
            self._f = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- internals -------------------------------------------------------

    def _file(self):
        if self._f is None:
            raise StoreError("store is closed")
        return self._f

    def _flush(self, f):
        f.flush()
        if self._sync:
            if _fsync is not None:
                _fsync(f.fileno())
            elif _ossync is not None:
                _ossync()

    def _create(self):
        f = self._open(self.path, "wb")
        try:
            f.write(MAGIC)  # a short one is a torn header: made again at the next open
            self._flush(f)
        finally:
            f.close()
        if self._sync:
            _sync_dir(self.path)

    def _append_record(self, hdr, data, crc):
        # Three writes, not one concatenation: no second copy of the data
        # in RAM. used_bytes moves only once the whole record is flushed, so
        # after a failed write the next record overwrites the partial one.
        f = self._f
        f.seek(self.used_bytes)
        f.write(hdr)
        f.write(data)
        f.write(struct.pack("<I", crc))
        self._flush(f)
        n = self.used_bytes + _OVER + len(data)
        if f.tell() != n:
            raise OSError(_ENOSPC)  # a short write: FAT says so without an error
        self.used_bytes = n

    def _reopen(self):
        # The store file again, after a failed write: a new file object
        # drops what the failure left in the old one's buffer (CPython
        # would write it at the next seek, or fail there again), and the
        # file is cut back to its last whole record, so that the record
        # refused stays refused after a reset (where the port cannot cut,
        # its first byte is spoiled, as far as the filesystem lets). A file
        # system gone read-only still gives the file to read: what is
        # stored can still be sent. When even that fails the store is
        # closed and says so.
        try:
            self._f.close()
        except (OSError, AttributeError):  # its flush fails again; or no file
            pass
        self._f = f = None
        for mode in ("r+b", "rb"):
            try:
                f = self._open(self.path, mode)
                break
            except OSError:
                pass
        if f is None:
            return
        self._f = f
        u = self.used_bytes
        try:
            if hasattr(f, "truncate"):
                f.truncate(u)
            else:
                # no truncate (MicroPython): a 0 over the refused record's
                # sync byte, where the filesystem still takes one
                f.seek(0, 2)
                if f.tell() > u:
                    f.seek(u)
                    f.write(b"\0")
                    f.flush()
        except OSError:
            pass

    def _err(self, e):
        # OSError e as acomm's error: one line naming the store and the cause
        n = e.args[0] if e.args else 0
        if n == _ENOSPC:
            return StoreFull("store %s: filesystem full" % self.path)
        if n == _EROFS:
            why = "read-only file system"
        elif n == _EACCES:
            why = "permission denied"
        else:
            why = getattr(e, "strerror", None) or str(e)
        return StoreError("store %s: %s" % (self.path, why))

    def _find(self, key):
        # The keys bytearray is searched in C; a hit must sit on a 4-byte
        # boundary (the pattern can straddle two keys).
        if not 0 <= key <= 0xFFFFFFFF:
            return -1
        pat = struct.pack("<I", key)
        ks = self._keys
        i = ks.find(pat)
        while i >= 0 and i & 3:
            i = ks.find(pat, i + 1)
        return i >> 2 if i >= 0 else -1

    def _drop(self, j):
        # Forget index slot j; its record becomes dead bytes.
        n = struct.unpack_from("<H", self._locs, 6 * j + 4)[0]
        self._keys[4 * j : 4 * j + 4] = b""
        self._locs[6 * j : 6 * j + 6] = b""
        self.live_bytes -= _OVER + n
        self.dead_bytes += _OVER + n

    def _maybe_compact(self):
        if self.dead_bytes > _MIN_DEAD and 2 * self.dead_bytes > self.used_bytes:
            self._compact_if_room()

    def _compact_if_room(self):
        # -> False when the filesystem has no room for the rewritten copy,
        # or takes no writes (compact() leaves the store as it was then)
        try:
            self.compact()
        except StoreError:
            return False
        return True

    def _copy(self, off, n, g):
        f = self._f
        mv = self._mv
        f.seek(off)
        while n:
            k = n if n < _CHUNK else _CHUNK
            f.readinto(mv[:k])
            g.write(mv[:k])
            n -= k

    def _parse(self, p, size):
        # The record at p if it is whole and checks: (kind, key, length),
        # else None. Reads through the small buffer: data never sits in RAM.
        if p + _OVER > size:
            return None
        f = self._f
        buf = self._buf
        mv = self._mv
        f.seek(p)
        if f.readinto(mv[:_HDR]) != _HDR:
            return None
        sync, kind, key, n = struct.unpack_from("<BBIH", buf, 0)
        if sync != _SYNC or not (kind == _PUT or (kind == _DEL and n == 0)) or p + _OVER + n > size:
            return None
        crc = crc32(mv[:_HDR])
        left = n
        while left:
            k = left if left < _CHUNK else _CHUNK
            if f.readinto(mv[:k]) != k:
                return None
            crc = crc32(mv[:k], crc)
            left -= k
        if f.readinto(mv[:4]) != 4 or struct.unpack_from("<I", buf, 0)[0] != crc:
            return None
        return kind, key, n

    def _next_good(self, p, size):
        # The first offset >= p that starts a record which checks, or -1.
        f = self._f
        buf = self._buf
        while p < size:
            f.seek(p)
            k = f.readinto(buf)
            if not k:
                return -1
            i = buf.find(_SYNC_B, 0, k)
            if i < 0:
                p += k
                continue
            if self._parse(p + i, size) is not None:
                return p + i
            p += i + 1
        return -1

    def _recover(self):
        f = self._f
        f.seek(0, 2)
        size = f.tell()
        f.seek(0)
        head = f.read(len(MAGIC))
        if head != MAGIC:
            if head != MAGIC[: len(head)]:
                self.close()
                raise StoreError("not an acomm store: " + self.path)
            # cut while the header was being written: nothing was stored yet
            f.close()
            self._create()
            self._f = f = self._open(self.path, "r+b")
            size = len(MAGIC)
        p = len(MAGIC)
        while p < size:
            r = self._parse(p, size)
            if r is None:
                q = self._next_good(p + 1, size)
                if q < 0:
                    break  # torn tail
                self.stats["corrupt_dropped"] += 1
                self.dead_bytes += q - p
                p = q
                continue
            kind, key, n = r
            j = self._find(key)
            if j >= 0:
                self._drop(j)
            if kind == _PUT:
                self._keys.extend(struct.pack("<I", key))
                self._locs.extend(struct.pack("<IH", p, n))
                self.live_bytes += _OVER + n
            else:
                self.dead_bytes += _OVER
            p += _OVER + n
        self.used_bytes = p
        if p < size:
            self.stats["torn_dropped"] += 1
            if hasattr(f, "truncate"):
                f.truncate(p)
                self._flush(f)
            else:
                self.compact()
                return
        self._maybe_compact()
