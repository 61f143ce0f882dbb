# acomm.codec.flat, the fast path of messages whose fields are flat
# (scalars and optional scalars), gives the same bytes, values and errors
# as the fields' own encode and decode: every such message of every
# catalog, with values decoded from random bodies, values that are wrong
# (out of range, NaN, wrong type, missing, not a dict), and bodies that are
# random, corrupted or short. The reference is a twin catalog whose
# fields wrap the same fields in a type the fast path does not plan for.
from acomm.codec.bits import BitReader, BitWriter
from acomm.catalog import MODULES, load
from acomm.codec import flat
from acomm.codec.message import Catalog, Message
from acomm.errors import AcommError
from acomm.prng import Prng


class _FieldByField:
    # a field as it is, but not a Scalar: flat.plan() refuses it, so its
    # message encodes and decodes field by field
    def __init__(self, f):
        self.f = f
        self.name, self.max_bits, self.min_bits, self.limit_bits = f.name, f.max_bits, f.min_bits, f.limit_bits

    def encode(self, w, v):
        self.f.encode(w, v)

    def decode(self, r):
        return self.f.decode(r)


def _twin(cat):
    ms = [Message(m.name, m.msg_id, [_FieldByField(f) for f in m.fields]) for m in cat.messages]
    return Catalog(cat.name, cat.id_bits, ms)


def _messages():
    # -> [((catalog, message), (its twin catalog, twin message))] for every flat message
    out = []
    for name in MODULES:
        try:
            cat = load(name)
        except ImportError:
            continue
        twin = None
        for m in cat.messages:
            if flat.plan(m.fields) is not None:
                twin = twin or _twin(cat)
                out.append(((cat, m), (twin, twin[m.name])))
    return out


def _both(pair, fn):
    # -> (fast result, reference result) of fn(catalog, message); each a
    # value (messages by name) or (error type, text, field)
    got = []
    for cat, m in pair:
        try:
            v = fn(cat, m)
            got.append([(x.name, d) for x, d in v] if isinstance(v, list) else v)
        except AcommError as e:
            got.append((type(e).__name__, str(e), getattr(e, "field", None)))
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
    names = [m.name for (_, m), _ in _messages()]
    assert "thrust" in names and "diver_reply" in names and "diver_status" in names
    assert any(flat.groups(flat.plan(m.fields)) is None for (_, m), _ in _messages())  # optionals: field by field
    assert all(flat.plan(t.fields) is None for _, (_, t) in _messages() if t.fields)  # the twins: the reference


def test_fast_path_gives_the_same_bytes_values_and_errors():
    rng = Prng(26)
    checked = 0
    for pair in _messages():
        cat, m = pair[0]
        nbytes = (cat.id_bits + m.max_bits + 7) >> 3
        for k in range(12):
            body = rng.bytes((m.max_bits + 7) >> 3)
            a, b = _both(pair, lambda cat, m: m.decode_from(BitReader(body)))
            assert a == b, (m.name, body, a, b)
            if isinstance(a, dict):
                good = a
                x, y = _both(pair, lambda cat, m: cat.pack([(m, good)]))
                assert x == y, (m.name, good, x, y)
                if k == 0:
                    for bad in _wrong(m, good, rng):
                        x, y = _both(pair, lambda cat, m: cat.pack([(m, bad)]))
                        assert x == y, (m.name, bad, x, y)
                # short bodies: every length fails (or not) at the same field
                wire = cat.pack([(m, good)])
                # the same frame with its last bit set (padding, or not)
                odd = wire[:-1] + bytes([wire[-1] | 1]) if wire else b"\x01"
                x, y = _both(pair, lambda cat, m: cat.unpack(odd))
                assert x == y, (m.name, odd, x, y)
                for cut in range(len(wire) + 1):
                    for nbits in (cut * 8, max(0, cut * 8 - 3)):
                        x, y = _both(pair, lambda cat, m: cat.unpack(wire[:cut], nbits))
                        assert x == y, (m.name, cut, nbits, x, y)
            # random frames: unpack's fast path for one message, or not
            for n in (1, len(body) + 1, len(body) + 2):
                junk = bytes([m.msg_id << (8 - cat.id_bits) & 0xFF]) + rng.bytes(n - 1)
                x, y = _both(pair, lambda cat, m: cat.unpack(junk))
                assert x == y, (m.name, junk, x, y)
            checked += 1
        # a writer too small for the message: field by field, same error
        zero = m.decode_from(BitReader(bytes(nbytes)))
        x, y = _both(pair, lambda cat, m: m.encode_into(BitWriter(bytearray(max(1, nbytes - 1))), zero))
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
