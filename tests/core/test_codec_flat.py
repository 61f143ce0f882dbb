# acomm.codec.flat, the fast path of messages whose fields are flat
# (scalars and optional scalars), gives the same bytes, values and errors
# as the fields' own encode and decode: every such message of every
# catalog, with values decoded from random bodies, values that are wrong
# (out of range, NaN, wrong type, missing, not a dict), and bodies that are
# random, corrupted or short. The reference is the same Message with its
# fast path turned off.
from acomm.codec.bits import BitReader, BitWriter
from acomm.catalog import MODULES, load
from acomm.codec import flat
from acomm.errors import AcommError
from acomm.prng import Prng


def _messages():
    out = []
    for name in MODULES:
        try:
            cat = load(name)
        except ImportError:
            continue
        for m in cat.messages:
            if m._fast() is not None:
                out.append((cat, m))
    return out


def _both(m, fn):
    # -> (fast result, reference result); each a value or (error type, text, field)
    got = []
    for fast in (True, False):
        saved = m._flat
        if not fast:
            m._flat = None
        try:
            got.append(fn())
        except AcommError as e:
            got.append((type(e).__name__, str(e), getattr(e, "field", None)))
        finally:
            m._flat = saved
    return got


def _wrong(m, good, rng):
    # value dicts with one thing wrong each
    out = ["not a dict", None, {}]
    for f in m.fields:
        for bad in (10 ** 9, -(10 ** 9), float("nan"), "text", None, [1]):
            v = dict(good)
            v[f.name] = bad
            out.append(v)
        v = dict(good)
        del v[f.name]
        out.append(v)
    return out


def test_flat_messages_exist_in_the_catalogs():
    names = [m.name for _, m in _messages()]
    assert "thrust" in names and "diver_reply" in names and "diver_status" in names
    assert any(m._groups is None for _, m in _messages())  # optionals: field by field


def test_fast_path_gives_the_same_bytes_values_and_errors():
    rng = Prng(26)
    checked = 0
    for cat, m in _messages():
        nbytes = (cat.id_bits + m.max_bits + 7) >> 3
        for k in range(12):
            body = rng.bytes((m.max_bits + 7) >> 3)
            a, b = _both(m, lambda: m.decode_from(BitReader(body)))
            assert a == b, (m.name, body, a, b)
            if isinstance(a, dict):
                good = a
                x, y = _both(m, lambda: cat.pack([(m, good)]))
                assert x == y, (m.name, good, x, y)
                if k == 0:
                    for bad in _wrong(m, good, rng):
                        x, y = _both(m, lambda: cat.pack([(m, bad)]))
                        assert x == y, (m.name, bad, x, y)
                # short bodies: every length fails (or not) at the same field
                wire = cat.pack([(m, good)])
                # the same frame with its last bit set (padding, or not)
                odd = wire[:-1] + bytes([wire[-1] | 1]) if wire else b"\x01"
                x, y = _both(m, lambda: cat.unpack(odd))
                assert x == y, (m.name, odd, x, y)
                for cut in range(len(wire) + 1):
                    for nbits in (cut * 8, max(0, cut * 8 - 3)):
                        x, y = _both(m, lambda: cat.unpack(wire[:cut], nbits))
                        assert x == y, (m.name, cut, nbits, x, y)
            # random frames: unpack's fast path for one message, or not
            for n in (1, len(body) + 1, len(body) + 2):
                junk = bytes([m.msg_id << (8 - cat.id_bits) & 0xFF]) + rng.bytes(n - 1)
                x, y = _both(m, lambda: cat.unpack(junk))
                assert x == y, (m.name, junk, x, y)
            checked += 1
        # a writer too small for the message: field by field, same error
        zero = m.decode_from(BitReader(bytes(nbytes)))
        x, y = _both(m, lambda: m.encode_into(BitWriter(bytearray(max(1, nbytes - 1))), zero))
        assert x == y, (m.name, x, y)
    assert checked > 100


def test_plan_refuses_what_it_cannot_do():
    from acomm.codec.fields import Bytes, Fixed, Optional, UInt, Wide

    assert flat.plan((UInt("a", 0, 3), Optional(Fixed("b", 0.0, 1.0, 0.1)))) is not None
    assert flat.plan((Bytes("a", 4),)) is None
    assert flat.plan((UInt("a", 0, 2 ** 25),)) is None  # wider than a group
    assert flat.plan((Wide(UInt("a", 0, 3), 8),)) is not None
    g = flat.groups(flat.plan((UInt("a", 0, 2 ** 20), UInt("b", 0, 2 ** 20), UInt("c", 0, 1))))
    assert [n for n, _ in g] == [21, 22]
