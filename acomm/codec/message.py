# Message schemas and catalogs (docs/codec.md).
#
# A Message is a name, a small numeric id and a tuple of fields; its values
# are a dict keyed by field name. A Catalog gives a set of messages an id
# space of id_bits and packs several of them back to back into one frame:
# id + body for each, no padding in between, zero bits to the byte at the
# end. Errors name the message and the field ("diver_reply.depth: ...") and
# carry them as attributes: message, field, detail.

import math

from .bits import BitReader, BitWriter
from ..errors import DecodeError, EncodeError
from .fields import fail, pathed

_flat = None  # acomm.codec.flat, imported at the first use of a Message


def _top(e, msg_name):
    # The error as the caller sees it: "message.field: detail".
    path = getattr(e, "field", None)
    detail = getattr(e, "detail", None) or str(e)
    full = msg_name if not path else msg_name + ("" if path[0] == "[" else ".") + path
    out = type(e)(full + ": " + detail)
    out.message = msg_name
    out.field = path
    out.detail = detail
    return out


class Message:
    """A message: a name, a small id and its fields in order; encodes values dicts to bits and back."""

    def __init__(self, name, msg_id, fields):
        """fields: acomm.codec.fields instances with distinct names; ValueError for a duplicate."""
        self.name = name
        self.msg_id = self.id = msg_id  # id: the short name catalogs use
        self.fields = tuple(fields)
        seen = {}
        for f in self.fields:
            if f.name in seen:
                raise ValueError("%s: duplicate field %r" % (name, f.name))
            seen[f.name] = f
        self.max_bits = sum(f.max_bits for f in self.fields)
        self.min_bits = sum(f.min_bits for f in self.fields)
        self.limit_bits = float(sum(f.limit_bits for f in self.fields))
        self._buf = bytearray((self.max_bits + 7) >> 3)
        # flat fields (acomm.codec.flat): a faster path, same bits and errors;
        # planned at first use, so a board that never packs one pays nothing
        self._flat = False
        self._groups = self._whole = None

    def __repr__(self):
        return "<Message %s id=%d>" % (self.name, self.msg_id)

    def field(self, name):
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(name)

    def _fast(self):
        # -> the flat plan, or None when the fields are not all flat
        global _flat
        if _flat is None:
            from . import flat as _flat
        p = self._flat
        if p is False:
            p = self._flat = _flat.plan(self.fields)
            self._groups = _flat.groups(p) if p is not None else None
            if self._groups is not None:
                self._whole = _flat.whole(p)
        return p

    # Bodies without the message name in errors: Nested uses these, and the
    # public methods below add the name.
    def encode_body(self, w, values):
        p = self._flat
        if p is False:
            p = self._fast()
        if p is not None and w.bit_length + self.max_bits <= w.capacity:
            return _flat.encode(w, values, p)
        f = None
        try:
            for f in self.fields:
                f.encode(w, values[f.name])
        except EncodeError as e:
            raise pathed(e, f.name) from None
        except KeyError:
            raise fail(EncodeError, "missing", f.name) from None
        except (TypeError, ValueError, AttributeError, IndexError):
            # values that are not a dict, or a field value of the wrong type
            if f is None or not isinstance(values, dict):
                raise fail(EncodeError, "values must be a dict, not %s" % type(values).__name__) from None
            raise fail(EncodeError, "bad value %r" % (values.get(f.name),), f.name) from None

    def decode_body(self, r):
        p = self._flat
        if p is False:
            p = self._fast()
        if p is not None:
            return _flat.decode(r, p, self._groups if r.remaining >= self.max_bits else None, {})
        out = {}
        f = None
        try:
            for f in self.fields:
                out[f.name] = f.decode(r)
        except DecodeError as e:
            raise pathed(e, f.name) from None
        return out

    def encode_into(self, w, values):
        try:
            self.encode_body(w, values)
        except EncodeError as e:
            raise _top(e, self.name) from None

    def decode_from(self, r):
        try:
            return self.decode_body(r)
        except DecodeError as e:
            raise _top(e, self.name) from None

    def encode(self, values):
        """values dict -> the body alone, zero-padded to whole bytes; EncodeError for a value out of its field."""
        w = BitWriter(self._buf)
        self.encode_into(w, values)
        return w.getvalue()

    def decode(self, buf):
        """The inverse of encode -> values dict; DecodeError for anything but zero padding after the body."""
        r = BitReader(buf)
        out = self.decode_from(r)
        rem = r.remaining
        if rem >= 8 or (rem and r.read(rem)):
            raise _top(fail(DecodeError, "%d bits of trailing data" % rem), self.name)
        return out

    def check_mtu(self, mtu_bytes, id_bits=0):
        # Raises EncodeError when the worst case does not fit; returns the
        # worst case in bits otherwise.
        need = self.max_bits + id_bits
        if (need + 7) >> 3 > mtu_bytes:
            raise _top(fail(EncodeError, "worst case %d bits does not fit an MTU of %d bytes" % (need, mtu_bytes)), self.name)
        return need


class Catalog:
    """Messages with ids of id_bits bits; packs several (message, values) into one frame and back."""

    def __init__(self, name, id_bits, messages):
        """ValueError when an id does not fit id_bits or two messages share one."""
        self.name = name
        self.id_bits = id_bits
        self.messages = tuple(messages)
        self._by_id = {}
        self._by_name = {}
        for m in self.messages:
            if not 0 <= m.msg_id < (1 << id_bits):
                raise ValueError("%s: id %d of %s does not fit %d bits" % (name, m.msg_id, m.name, id_bits))
            if m.msg_id in self._by_id:
                raise ValueError("%s: id %d used by %s and %s" % (name, m.msg_id, self._by_id[m.msg_id].name, m.name))
            if m.name in self._by_name:
                raise ValueError("%s: two messages named %s" % (name, m.name))
            # Zero padding at the end of a frame is under 8 bits. A message
            # with id 0 that can be shorter than 8 bits could be all zeros
            # there and be taken for padding, so unpack would lose it.
            if m.msg_id == 0 and id_bits + m.min_bits < 8:
                raise ValueError("%s: id 0 (%s) needs at least %d body bits, so padding is never a message" % (name, m.name, 8 - id_bits))
            self._by_id[m.msg_id] = m
            self._by_name[m.name] = m
        # log2 of the number of messages: what the id tells
        self.id_limit_bits = math.log2(len(self.messages)) if self.messages else 0.0

    def __getitem__(self, name):
        return self._by_name[name]

    def __contains__(self, m):
        return self._by_name.get(getattr(m, "name", m)) is not None

    def by_id(self, msg_id):
        return self._by_id.get(msg_id)

    def bits(self, m):
        return self.id_bits + self._get(m).max_bits

    def limit_bits(self, m):
        return self.id_limit_bits + self._get(m).limit_bits

    def _get(self, m):
        # A Message of this catalog, or its name.
        got = self._by_name.get(m) if isinstance(m, str) else self._by_id.get(getattr(m, "msg_id", None))
        if got is None or (not isinstance(m, str) and got is not m):
            raise fail(EncodeError, "%r is not a message of catalog %s" % (m, self.name))
        return got

    def pack_into(self, w, items):
        # Writes id + body of each (message, values) pair. On EncodeError the
        # writer holds a partial frame: reset it before reuse.
        for m, values in items:
            m = self._get(m)
            w.write(m.msg_id, self.id_bits)
            m.encode_into(w, values)

    def pack(self, items):
        """[(message, values dict), ...] -> bytes; EncodeError for a value outside its field."""
        if type(items) is not list:
            items = list(items)
        if len(items) == 1:
            # one message of flat fields: the frame as one int (codec.flat)
            m, values = items[0]
            if self._by_id.get(getattr(m, "msg_id", None)) is not m:
                m = self._get(m)  # a name, or not a message of this catalog
            p = m._flat
            if p is False:
                p = m._fast()
            if p is not None:
                try:
                    out = _flat.pack_one(m.msg_id, self.id_bits, values, p, m.max_bits)
                except EncodeError as e:
                    raise _top(e, m.name) from None
                if out is not None:
                    return out
        need = 0
        for m, _ in items:
            need += self.bits(m)
        w = BitWriter(bytearray((need + 7) >> 3))
        self.pack_into(w, items)
        return w.getvalue()

    def unpack(self, buf, nbits=None):
        """bytes -> [(message, values dict), ...]; DecodeError when they do not parse."""
        # Messages until only zero padding is left: fewer than 8 bits, all
        # zero. Anything else must parse as id + body; when it does not, the
        # DecodeError's `messages` holds what was decoded before it.
        if _flat is not None:
            # a frame of one message of flat fields, planned (codec.flat)
            one = _flat.unpack_one(self._by_id, self.id_bits, buf, nbits)
            if one is not None:
                return one
        r = BitReader(buf, nbits)
        out = []
        while True:
            rem = r.remaining
            if rem == 0:
                return out
            if rem < 8:
                pos = r.position
                if r.read(rem) == 0:
                    return out
                r = BitReader(buf, nbits)
                r.skip(pos)
            try:
                mid = r.read(self.id_bits)
            except DecodeError as e:
                raise self._err(e, out, "id", None) from None
            m = self._by_id.get(mid)
            if m is None:
                raise self._err(fail(DecodeError, "unknown message id %d" % mid), out, "id", None)
            try:
                values = m.decode_body(r)
            except DecodeError as e:
                raise self._err(e, out, None, m) from None
            out.append((m, values))

    def _err(self, e, done, path, m):
        detail = getattr(e, "detail", None) or str(e)
        if m is not None:
            path = getattr(e, "field", None)
            where = m.name if not path else m.name + ("" if path[0] == "[" else ".") + path
        else:
            where = path
        out = type(e)("%s.%s: %s (after %d messages)" % (self.name, where, detail, len(done)))
        out.catalog = self.name
        out.message = m.name if m is not None else None
        out.field = path
        out.detail = detail
        out.messages = done
        return out
