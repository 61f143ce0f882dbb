# The fast path of a Message whose fields are all flat: scalars (UInt,
# Fixed, Enum, Bool, Wide of at most 24 bits) or Optional scalars, planned
# at the message's first use (acomm.codec.message). A catalog frame that
# holds one such message is packed into one int and unpacked from one
# (pack_one, unpack_one: up to 62 bits on 64-bit runtimes, 30 on 32-bit
# boards, where larger ints would allocate). Otherwise encode gathers the
# codes of several fields into one small int and writes it at once, and
# decode reads the body of an all-scalar message in groups of fields of at
# most 24 bits and splits each group by shifts. Same bits, values and
# errors (with the same field paths) as the fields' own encode and decode,
# which Message uses when this path does not apply, or, for unpack_one,
# whenever anything is wrong with the frame (tests/core/test_codec_flat.py
# compares the two on every flat message of every catalog).

import sys

from ..errors import DecodeError, EncodeError
from .fields import Optional, Scalar, fail, pathed

_MAX_FIELD = 24  # bits of one field on this path
_MAX_ACC = 29  # bits gathered before a write
# a whole frame held in one int (pack_one, unpack_one) up to this many bits:
# a small int on 64-bit ports (no allocation), 30 bits on 32-bit boards
_WHOLE = 62 if sys.maxsize > (1 << 32) else 30


def plan(fields):
    """-> ((name, scalar, optional, bits), ...) for flat fields, else None."""
    out = []
    for f in fields:
        opt = isinstance(f, Optional)
        s = f.field if opt else f
        if not isinstance(s, Scalar) or type(s).encode is not Scalar.encode or type(s).decode is not Scalar.decode:
            return None
        if s.bits > _MAX_FIELD:
            return None
        out.append((s.name, s, opt, s.bits))
    return tuple(out)


def groups(p):
    """-> ((group bits, ((name, scalar, shift, mask), ...)), ...) for an all-scalar plan, else None."""
    out = []
    cur = []
    n = 0
    for name, s, opt, bits in p:
        if opt:
            return None
        if n + bits > _MAX_FIELD and cur:
            out.append((n, _shifts(cur, n)))
            cur = []
            n = 0
        cur.append((name, s, bits))
        n += bits
    if cur:
        out.append((n, _shifts(cur, n)))
    return tuple(out)


def _shifts(cur, n):
    out = []
    for name, s, bits in cur:
        n -= bits
        out.append((name, s, n, (1 << bits) - 1))
    return tuple(out)


def _encode_failed(e, values, name):
    # Raises the EncodeError of Message.encode_body for what a field loop
    # caught (e) at field `name`. Shared by encode() and pack_one(), outside
    # their loops: the fast path makes no call for it.
    if isinstance(e, EncodeError):
        raise pathed(e, name) from None
    if isinstance(e, KeyError):
        raise fail(EncodeError, "missing", name) from None
    if name is None or not isinstance(values, dict):
        raise fail(EncodeError, "values must be a dict, not %s" % type(values).__name__) from None
    raise fail(EncodeError, "bad value %r" % (values.get(name),), name) from None


def encode(w, values, p):
    """Writes the body; the errors of Message.encode_body, with their paths."""
    acc = 0
    n = 0
    name = None
    try:
        for name, s, opt, bits in p:
            v = values[name]
            if n + bits >= _MAX_ACC:
                w.write(acc, n)
                acc = 0
                n = 0
            if opt:
                if v is None:
                    acc <<= 1
                    n += 1
                    continue
                acc = (acc << 1) | 1
                n += 1
            acc = (acc << bits) | s.code(v)
            n += bits
    except (EncodeError, KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        _encode_failed(e, values, name)
    if n:
        w.write(acc, n)


def pack_one(msg_id, id_bits, values, p, max_bits):
    """One message's frame (id + body, zero-padded) -> bytes, or None when
    it may be longer than _WHOLE bits; the errors of Message.encode_body."""
    if id_bits + max_bits > _WHOLE:
        return None
    acc = msg_id
    n = id_bits
    name = None
    try:
        for name, s, opt, bits in p:
            v = values[name]
            if opt:
                if v is None:
                    acc <<= 1
                    n += 1
                    continue
                acc = (acc << 1) | 1
                n += 1
            acc = (acc << bits) | s.code(v)
            n += bits
    except (EncodeError, KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        _encode_failed(e, values, name)
    pad = (8 - (n & 7)) & 7
    return (acc << pad).to_bytes((n + pad) >> 3, "big")


def unpack_one(by_id, id_bits, buf, nbits):
    """[(message, values)] when buf holds exactly one flat message and its
    zero padding, all of it right; None otherwise (the caller decodes field
    by field, and so raises what it raises)."""
    total = len(buf) * 8
    if total > _WHOLE + 8 or total < 8:
        return None
    nb = total if nbits is None else nbits
    if nb < id_bits or nb > total:
        return None
    v = int.from_bytes(buf, "big") >> (total - nb)
    m = by_id.get(v >> (nb - id_bits))
    if m is None or not m._flat:
        return None
    if m._groups is None:
        return _unpack_optionals(m, v, nb - id_bits)
    rem = nb - id_bits - m.max_bits
    if rem < 0 or rem >= 8 or v & ((1 << rem) - 1):
        return None
    out = {}
    for name, s, off, mask in m._whole:
        c = (v >> (rem + off)) & mask
        if c >= s.ncodes:
            return None
        out[name] = s.value(c)
    return [(m, out)]


def _unpack_optionals(m, v, shift):
    # the same for a body with optional fields: positions found as it goes
    out = {}
    for name, s, opt, bits in m._flat:
        if opt:
            shift -= 1
            if shift < 0:
                return None
            if not (v >> shift) & 1:
                out[name] = None
                continue
        shift -= bits
        if shift < 0:
            return None
        c = (v >> shift) & ((1 << bits) - 1)
        if c >= s.ncodes:
            return None
        out[name] = s.value(c)
    if shift >= 8 or v & ((1 << shift) - 1):
        return None
    return [(m, out)]


def whole(p):
    """-> ((name, scalar, bits after it, mask), ...) of an all-scalar plan."""
    out = []
    off = 0
    for name, s, _, bits in reversed(p):
        out.append((name, s, off, (1 << bits) - 1))
        off += bits
    out.reverse()
    return tuple(out)


def decode(r, p, gs, out):
    """Fills out with the body's values; the errors of Message.decode_body.

    gs (groups(p)) only when at least the message's bits remain: a short
    body then fails at the same field as field by field."""
    if gs is not None:
        for n, fs in gs:
            v = r.read(n)
            for name, s, shift, mask in fs:
                c = (v >> shift) & mask
                if c >= s.ncodes:
                    raise fail(DecodeError, "code %d past the last %d" % (c, s.ncodes - 1), name)
                out[name] = s.value(c)
        return out
    name = None
    try:
        for name, s, opt, bits in p:
            if opt and not r.read(1):
                out[name] = None
                continue
            c = r.read(bits)
            if c >= s.ncodes:
                raise fail(DecodeError, "code %d past the last %d" % (c, s.ncodes - 1))
            out[name] = s.value(c)
    except DecodeError as e:
        raise pathed(e, name) from None
    return out
