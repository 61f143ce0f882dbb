# acomm.transport.store on real files, on both runtimes. Each test works in its own
# folder under /tmp and removes it, whatever happens.

import os
from collections import OrderedDict

from checks import TempDir, raises, skip
from faultfs import FaultFS

from acomm.codec._crc32_pure import crc32_pure
from acomm.codec.crc32 import crc32
from acomm.errors import AcommError, EncodeError, StoreError, StoreFull
from acomm.prng import Prng
from acomm.transport.store import MAGIC, Store

HDR = len(MAGIC)


_Dir = TempDir


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def _write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def _size(path):
    return os.stat(path)[6]


def _data(key, ver=0):
    # Verifiable from the key; starts with a sync byte and a kind byte so
    # that resynchronisation has decoys to reject.
    n = 1 + (key * 13 + ver * 5) % 90
    return b"\xa5P" + bytes([(key * 31 + ver * 7 + i) & 0xFF for i in range(n)])


def _rec_len(key, ver=0):
    return 12 + len(_data(key, ver))


def _check(s, want):
    # The store holds exactly `want` (key -> data, an OrderedDict: plain
    # dicts are unordered on MicroPython), in that order.
    assert s.keys() == list(want), (s.keys(), list(want))
    assert len(s) == len(want)
    for k in want:
        assert k in s
        assert s.get(k) == want[k], k


def test_crc32_check_values():
    for fn in (crc32, crc32_pure):
        assert fn(b"123456789") == 0xCBF43926
        assert fn(b"") == 0
        assert fn(b"6789", fn(b"12345")) == 0xCBF43926
    d = Prng(5).bytes(300)
    assert crc32(d) == crc32_pure(d)
    assert crc32(memoryview(d)[7:99]) == crc32_pure(d[7:99])


def test_crc32_matches_zlib():
    try:
        import zlib
    except ImportError:
        return  # MicroPython: the check values above stand in
    rng = Prng(9)
    for n in (0, 1, 3, 64, 255, 1000):
        d = rng.bytes(n)
        assert crc32_pure(d) == zlib.crc32(d)
        assert crc32_pure(d, 0x12345678) == zlib.crc32(d, 0x12345678)


def test_put_get_delete_reopen():
    with _Dir() as d:
        s = Store(d.file())
        assert len(s) == 0 and s.keys() == [] and s.get(1) is None
        assert s.used_bytes == HDR == _size(d.file())
        want = OrderedDict()
        for k in (7, 0, 0xFFFFFFFF, 123456, 42):
            s.put(k, _data(k))
            want[k] = _data(k)
        s.put(99, b"")  # an empty packet is a packet
        want[99] = b""
        _check(s, want)
        s.delete(0)
        s.delete(5)  # unknown: ignored
        del want[0]
        _check(s, want)
        assert s.stats["appends"] == 6 and s.stats["deletes"] == 1
        assert s.used_bytes == _size(d.file())
        s.close()
        raises(StoreError, s.get, 7)
        with Store(d.file()) as s2:
            _check(s2, want)
            assert s2.stats["torn_dropped"] == 0 and s2.stats["corrupt_dropped"] == 0
            assert s2.live_bytes == sum(12 + len(v) for v in want.values())


def test_replace_keeps_latest_in_put_order():
    with _Dir() as d:
        s = Store(d.file())
        for k in (1, 2, 3):
            s.put(k, _data(k))
        s.put(1, _data(1, 1))
        want = OrderedDict(((2, _data(2)), (3, _data(3)), (1, _data(1, 1))))
        _check(s, want)
        assert s.dead_bytes == _rec_len(1)
        s.close()
        s = Store(d.file())
        _check(s, want)
        assert s.dead_bytes == _rec_len(1)
        s.close()


def test_bad_arguments():
    with _Dir() as d:
        s = Store(d.file(), max_record=100)
        raises(EncodeError, s.put, -1, b"x")
        raises(EncodeError, s.put, 1 << 32, b"x")
        raises(EncodeError, s.put, 1, bytes(101))
        s.put(1, bytes(100))
        assert s.get(-1) is None and (1 << 32) not in s
        s.delete(-1)
        assert s.keys() == [1]
        s.close()
        raises(StoreError, Store, d.file("t"), 1000, 70000)
        assert issubclass(StoreFull, AcommError)


def test_compact_manual():
    with _Dir() as d:
        s = Store(d.file())
        want = OrderedDict()
        for k in range(20):
            s.put(k, _data(k))
            want[k] = _data(k)
        for k in range(0, 20, 3):
            s.delete(k)
            del want[k]
        s.put(5, _data(5, 2))
        del want[5]
        want[5] = _data(5, 2)
        assert s.dead_bytes > 0
        s.compact()
        assert s.stats["compactions"] == 1
        assert s.dead_bytes == 0
        assert s.used_bytes == HDR + s.live_bytes == _size(d.file())
        _check(s, want)
        s.put(100, _data(100))  # appends still go to the end
        want[100] = _data(100)
        _check(s, want)
        s.close()
        s = Store(d.file())
        _check(s, want)
        assert s.dead_bytes == 0
        s.close()
        assert os.listdir(d.path) == ["s"]


def test_compact_automatic():
    with _Dir() as d:
        s = Store(d.file(), capacity_bytes=1 << 20)
        want = OrderedDict()
        for i in range(400):
            k = i % 10
            s.put(k, _data(k, i))
            want.pop(k, None)
            want[k] = _data(k, i)
            # dead bytes never stay above half the file for long
            assert s.dead_bytes <= 256 or 2 * s.dead_bytes <= s.used_bytes
        assert s.stats["compactions"] > 5
        assert s.used_bytes < 3000
        _check(s, want)
        s.close()
        s = Store(d.file())
        _check(s, want)
        s.close()


def _torn_case(last_op):
    # Cuts a copy of the file at every length inside its last record.
    with _Dir() as d:
        s = Store(d.file())
        want = OrderedDict()
        for k in (10, 11, 12, 13):
            s.put(k, _data(k))
            want[k] = _data(k)
        start = s.used_bytes
        if last_op == "new":
            s.put(14, _data(14))
        elif last_op == "replace":
            s.put(11, _data(11, 1))
        else:
            s.delete(12)
        end = s.used_bytes
        s.close()
        full = _read(d.file())
        assert len(full) == end
        for cut in range(start, end):
            p = d.file("cut")
            _write(p, full[:cut])
            c = Store(p)
            _check(c, want)  # the unfinished operation left no trace
            assert c.stats["torn_dropped"] == (1 if cut > start else 0)
            assert c.stats["corrupt_dropped"] == 0
            assert c.used_bytes == _size(p) <= start
            # appending after the cut gives a clean file
            c.put(77, _data(77))
            c.close()
            c = Store(p)
            assert c.get(77) == _data(77) and c.stats["torn_dropped"] == 0
            c.close()
            os.remove(p)


def test_torn_tail_new_record():
    _torn_case("new")


def test_torn_tail_replacement():
    _torn_case("replace")


def test_torn_tail_tombstone():
    _torn_case("delete")


def test_flipped_byte_drops_only_that_record():
    with _Dir() as d:
        s = Store(d.file())
        offs = []
        for k in range(5):
            offs.append(s.used_bytes)
            s.put(k, _data(k))
        end = s.used_bytes
        s.close()
        full = _read(d.file())
        a, b = offs[2], offs[3]  # record of key 2
        for i in range(a, b):
            bad = bytearray(full)
            bad[i] ^= 0x10
            p = d.file("bad")
            _write(p, bad)
            c = Store(p)
            assert c.keys() == [0, 1, 3, 4], (i, c.keys())
            for k in (0, 1, 3, 4):
                assert c.get(k) == _data(k)
            assert c.stats["corrupt_dropped"] == 1 and c.stats["torn_dropped"] == 0
            assert c.dead_bytes == b - a and c.used_bytes == end
            c.close()
            os.remove(p)


def _open_file_sees_other_writes(path):
    # False on littlefs (a board's filesystem): an open file keeps its view
    # of the file as it was opened and does not see what another handle
    # wrote since. Read far from where `a` read first, so that a buffer of
    # CPython's (8 KiB) does not answer from memory instead.
    _write(path, bytes(32768))
    with open(path, "rb") as a:
        a.read(1)
        with open(path, "r+b") as b:
            b.seek(30000)
            b.write(b"ZZ")
        a.seek(30000)
        seen = a.read(2) == b"ZZ"
    os.remove(path)
    return seen


def test_rot_after_open_is_caught_by_get():
    with _Dir() as d:
        if not _open_file_sees_other_writes(d.file("probe")):
            skip("rot written through a second handle is not seen by the store's open file on this filesystem")
        s = Store(d.file())
        for k in range(3):
            s.put(k, _data(k))
        with open(d.file(), "r+b") as f:
            f.seek(HDR + _rec_len(0) + 12)
            f.write(b"\x00\x00")
        assert s.get(1) is None
        assert s.stats["corrupt_dropped"] == 1 and s.keys() == [0, 2]
        s.close()


def test_capacity_and_store_full():
    with _Dir() as d:
        cap = HDR + 5 * 50
        s = Store(d.file(), capacity_bytes=cap)
        for k in range(5):
            s.put(k, bytes(38))  # 50 bytes each: exactly full
        assert s.used_bytes == cap
        e = raises(StoreFull, s.put, 5, b"x")
        assert isinstance(e, AcommError)
        raises(StoreFull, s.put, 1, bytes(38))  # a replacement needs room too
        assert s.keys() == [0, 1, 2, 3, 4] and s.used_bytes == cap
        # a delete without room for its tombstone compacts the record away
        s.delete(2)
        assert s.keys() == [0, 1, 3, 4] and s.used_bytes == cap - 50
        s.delete(3)  # tombstone: 12 more bytes
        s.put(5, bytes(38))  # needs the compaction put() does when full
        assert s.keys() == [0, 1, 4, 5] and s.used_bytes <= cap
        s.put(6, bytes(38))  # full again, exactly
        raises(StoreFull, s.put, 7, b"")
        assert s.used_bytes == cap
        s.close()
        s = Store(d.file(), capacity_bytes=cap)
        assert s.keys() == [0, 1, 4, 5, 6]
        s.close()
        s = Store(d.file("big"), capacity_bytes=100)
        raises(StoreFull, s.put, 1, bytes(90))  # never fits
        s.close()


def test_leftover_temp_file_is_removed():
    with _Dir() as d:
        s = Store(d.file())
        s.put(1, _data(1))
        s.put(2, _data(2))
        s.close()
        _write(d.file("s.tmp"), MAGIC + b"\xa5P\x01\x00")  # a cut compaction
        s = Store(d.file())
        _check(s, OrderedDict(((1, _data(1)), (2, _data(2)))))
        s.close()
        assert os.listdir(d.path) == ["s"]


def test_temp_file_without_store_file_is_used():
    # A FAT rename deletes the target first: a cut between the two steps
    # leaves only the finished temporary file.
    with _Dir() as d:
        s = Store(d.file())
        s.put(1, _data(1))
        s.put(2, _data(2))
        s.close()
        os.rename(d.file(), d.file("s.tmp"))
        s = Store(d.file())
        _check(s, OrderedDict(((1, _data(1)), (2, _data(2)))))
        s.close()
        assert os.listdir(d.path) == ["s"]


def test_torn_header_and_foreign_file():
    with _Dir() as d:
        for cut in range(HDR):
            _write(d.file(), MAGIC[:cut])
            s = Store(d.file())
            assert len(s) == 0 and _size(d.file()) == HDR
            s.put(3, b"abc")
            s.close()
            with Store(d.file()) as s:
                assert s.get(3) == b"abc"
            os.remove(d.file())
        _write(d.file(), b"some config\n")
        raises(StoreError, Store, d.file())
        assert _read(d.file()) == b"some config\n"  # left alone


def test_garbage_between_records_is_skipped():
    with _Dir() as d:
        s = Store(d.file())
        s.put(1, _data(1))
        s.close()
        junk = b"\xa5P\x00\x00\x00\x00\x05\x00\xa5\xa5D" + bytes(30)
        _write(d.file(), _read(d.file()) + junk)
        s = Store(d.file())
        assert s.stats["torn_dropped"] == 1 and _size(d.file()) == HDR + _rec_len(1)
        s.put(2, _data(2))
        s.close()
        # now in the middle
        full = _read(d.file())
        mid = HDR + _rec_len(1)
        _write(d.file(), full[:mid] + junk + full[mid:])
        s = Store(d.file())
        _check(s, OrderedDict(((1, _data(1)), (2, _data(2)))))
        assert s.stats["corrupt_dropped"] == 1 and s.dead_bytes == len(junk)
        s.close()


def test_record_bytes_as_documented():
    # docs/wire-format.md, "Store records", example
    with _Dir() as d:
        s = Store(d.file())
        s.put(7, b"hi")
        s.delete(7)
        s.close()
        assert _read(d.file()) == MAGIC + bytes.fromhex(
            "a55007000000020068695411" "2fe7" "a544070000000000" "5357ce2a"
        )


# Full, read-only and failing filesystems, through the store's opener
# (tests/core/faultfs.py; a real small filesystem in
# tests/cpython/test_store_full_disk.py).


def test_a_full_filesystem_refuses_a_put_and_keeps_what_was_there():
    for short in (False, True):  # ENOSPC, or FAT's short count without an error
        with _Dir() as d:
            fs = FaultFS()
            fs.short = short
            s = Store(d.file(), opener=fs.open)
            s.put(1, _data(1))
            fs.free = 5  # the next record's first bytes fit, then the disk is full
            e = raises(StoreFull, s.put, 2, _data(2))
            assert str(e) == "store %s: filesystem full" % d.file(), e
            assert s.keys() == [1] and s.get(1) == _data(1) and s.get(2) is None
            raises(StoreFull, s.put, 3, b"x")  # and again, with nothing left
            fs.free = None  # room again
            s.put(2, _data(2))  # over the torn start
            _check(s, OrderedDict(((1, _data(1)), (2, _data(2)))))
            s.close()
            s = Store(d.file())
            _check(s, OrderedDict(((1, _data(1)), (2, _data(2)))))
            assert s.stats["torn_dropped"] == 0
            s.close()


def test_a_refused_record_stays_refused_after_a_reopen():
    # the whole record reached the file but its flush failed: the store cuts
    # it off, so what put() refused never comes back after a reset
    with _Dir() as d:
        fs = FaultFS()
        s = Store(d.file(), opener=fs.open)
        s.put(1, _data(1))
        real = s._flush
        calls = []

        def flush_fails(f):
            calls.append(f)
            raise OSError(28)

        s._flush = flush_fails
        raises(StoreFull, s.put, 2, _data(2))
        s._flush = real
        assert calls and s.keys() == [1]
        s.close()
        s = Store(d.file())
        if s.stats["torn_dropped"] == 0:  # the port can truncate (CPython)
            assert _size(d.file()) == HDR + _rec_len(1)
        assert s.keys() == [1] and s.get(2) is None
        s.close()


def test_other_write_failures_are_a_store_error_with_the_cause():
    with _Dir() as d:
        fs = FaultFS()
        s = Store(d.file(), opener=fs.open)
        s.put(1, _data(1))
        fs.fail = 5  # EIO
        e = raises(StoreError, s.put, 2, _data(2))
        assert not isinstance(e, StoreFull) and str(e).startswith("store %s: " % d.file()), e
        assert s.keys() == [1]
        s.put(2, _data(2))  # the fault has passed
        fs.fail = 30  # the file system was remounted read-only
        e = raises(StoreError, s.put, 3, _data(3))
        assert str(e) == "store %s: read-only file system" % d.file()
        fs.fail = 5
        s.delete(1)  # a delete never raises for a failed write: deferred
        assert s.keys() == [2] and s.stats["delete_deferred"] == 1
        s.close()


def test_a_path_that_cannot_be_written_fails_at_open_with_one_line():
    with _Dir() as d:
        for errno, why in ((30, "read-only file system"), (13, "permission denied")):
            fs = FaultFS()
            fs.refuse = errno
            e = raises(StoreError, Store, d.file(), 65536, 1024, True, fs.open)  # no file yet
            assert str(e) == "store %s: %s" % (d.file(), why) and not isinstance(e, StoreFull), e
            s = Store(d.file())
            s.put(1, _data(1))
            s.close()
            e = raises(StoreError, Store, d.file(), 65536, 1024, True, fs.open)  # a store there
            assert str(e) == "store %s: %s" % (d.file(), why), e
            os.remove(d.file())
        # no room to create the store: StoreFull, and the store opens once there is
        fs = FaultFS(free=2)
        e = raises(StoreFull, Store, d.file(), 65536, 1024, True, fs.open)
        assert str(e) == "store %s: filesystem full" % d.file()
        fs.free = None
        s = Store(d.file(), opener=fs.open)
        s.put(1, _data(1))
        s.close()
        with Store(d.file()) as s:
            assert s.get(1) == _data(1)


def test_a_full_filesystem_defers_a_delete_until_a_compaction_fits():
    with _Dir() as d:
        fs = FaultFS()
        s = Store(d.file(), opener=fs.open)
        for k in (1, 2, 3):
            s.put(k, _data(k))
        fs.free = 0
        s.delete(2)  # no tombstone fits: forgotten now, not raised
        assert s.keys() == [1, 3] and s.get(2) is None and s.stats["delete_deferred"] == 1
        s.close()
        s = Store(d.file(), opener=fs.open)
        assert s.keys() == [1, 2, 3]  # a reset before a compaction brings it back
        fs.free = None
        s.delete(2)
        fs.free = 0
        s.delete(3)
        raises(StoreFull, s.compact)  # no room for the copy: the store is as it was
        assert s.keys() == [1] and s.get(1) == _data(1)
        assert sorted(os.listdir(d.path)) == ["s"]  # no half copy left taking room
        fs.free = None
        s.compact()  # room again: the deferred delete reaches the file
        s.close()
        s = Store(d.file())
        assert s.keys() == [1]
        s.close()


def test_a_compaction_with_no_room_does_not_fail_the_put_that_asked_for_it():
    with _Dir() as d:
        fs = FaultFS()
        s = Store(d.file(), capacity_bytes=100000, opener=fs.open)
        for v in range(40):  # dead bytes pile up past half the file
            if v > 20:
                fs.free = _rec_len(7, v)  # the record fits, the compaction's copy does not
            s.put(7, _data(7, v))
        assert s.get(7) == _data(7, 39) and s.dead_bytes > s.used_bytes // 2
        fs.free = None
        s.put(7, _data(7, 40))
        assert s.stats["compactions"] >= 1 and s.dead_bytes == 0
        assert s.get(7) == _data(7, 40)
        s.close()


def test_a_store_at_capacity_on_a_full_filesystem_still_answers():
    # both limits at once: the capacity wants a compaction, the filesystem
    # has no room for it; put() refuses, get() and keys() still work
    with _Dir() as d:
        fs = FaultFS()
        cap = HDR + 4 * 50
        s = Store(d.file(), capacity_bytes=cap, opener=fs.open)
        for k in range(4):
            s.put(k, bytes(38))
        s.delete(1)  # no room for the tombstone below capacity: compacted away
        s.put(1, bytes(26))  # 38 bytes: 12 left, enough for a tombstone
        s.delete(0)
        fs.free = 0
        raises(StoreFull, s.put, 6, bytes(38))  # the compaction it needs does not fit
        assert s.keys() == [2, 3, 1] and s.get(3) == bytes(38) and s.get(1) == bytes(26)
        fs.free = None
        s.put(6, bytes(38))
        assert s.keys() == [2, 3, 1, 6] and s.used_bytes <= cap
        s.close()


def test_a_filesystem_gone_read_only_still_gives_what_is_stored():
    # a file system remounted read-only after errors: writes fail with a
    # StoreError, deletes are deferred, and the records still read back
    with _Dir() as d:
        fs = FaultFS()
        s = Store(d.file(), opener=fs.open)
        for k in (1, 2, 3):
            s.put(k, _data(k))
        fs.refuse = 30
        fs.fail = 30
        e = raises(StoreError, s.put, 4, _data(4))
        assert str(e) == "store %s: read-only file system" % d.file()
        _check(s, OrderedDict((k, _data(k)) for k in (1, 2, 3)))
        s.delete(2)
        raises(StoreError, s.compact)
        _check(s, OrderedDict((k, _data(k)) for k in (1, 3)))
        raises(StoreError, s.put, 4, _data(4))
        s.close()
