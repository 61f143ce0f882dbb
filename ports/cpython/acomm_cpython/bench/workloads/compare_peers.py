# The systems users would pick instead of acomm, encoding compare_items'
# workload (CPython only; installed by `pip install .[bench]`):
#
#   imc       IMC 5.4 packets as DUNE sends them, serialized by imcpy: the
#             20-byte header, the closest IMC message(s), the 2-byte CRC
#   cbor      ROS 2 over rmw_desert (seed 004): the message's fields as one
#             CBOR array (cbor2) behind rmw_desert's 6-byte packet header
#   ltcodecs  WHOI ros_acomms' field codecs (ltcodecs), the fields as a
#             DictCodec, behind one byte naming the message codec
#
# Each peer is given the values on acomm's grid, in the form that costs it
# least, so a peer's bytes are a lower bound for that system:
#   - cbor gets integers (the value divided by the resolution, signed, as
#     an Int32 field of a ROS message would hold it) rather than floats,
#     which cbor2 writes as 9-byte doubles; seed 004's command is the same
#     shape (an Int32MultiArray of six small integers: 1 + 6 bytes of CBOR,
#     13 bytes with the header, the lower of the seed's 13-14);
#   - ltcodecs gets each field's exact range and number of values, so its
#     body has the same bits as acomm's (linspace_float / integer codecs);
#   - the log: seed 004 says rmw_desert compresses but not how, so cbor
#     gets the log under zlib at level 9 as a byte string; ltcodecs gets
#     the shorter of its lzma codec and its 7-bit ASCII string codec.
# Not modelled, and left out in the peers' favour: ros_acomms' own packet
# framing beyond the codec id byte (ros_acomms is not on PyPI; ltcodecs is
# its codec library), and any fragmentation a peer needs for the log
# (acomm's log is counted in fragments on a 256-byte Micro-Modem frame).

import importlib
import zlib

from acomm.codec.fields import Fixed, Nested, UInt
from acomm.codec.text6 import Text6

from acomm_cpython.bench.workloads import compare_items as ci

PEERS = ("imc", "cbor", "ltcodecs")
MODULES = {"imc": "imcpy", "cbor": "cbor2", "ltcodecs": "ltcodecs"}
RMW_DESERT_HEADER = 6  # seed 004 section III-B
LTCODECS_HEADER = 1  # the message codec id byte ros_acomms puts first
LTCODECS_ID = 101


def missing():
    # the peers whose package does not import here
    out = []
    for p in PEERS:
        try:
            importlib.import_module(MODULES[p])
        except ImportError:
            out.append(p)
    return out


def log_reference(data):
    # the limit stand-in for the log: its size under zlib at level 9
    return len(zlib.compress(data, 9))


def _flat(fields, values, prefix=""):
    # -> [(name, field, value)] of the scalar and text fields, nested
    # messages flattened in wire order
    out = []
    for f in fields:
        v = values[f.name]
        if isinstance(f, Nested):
            out.extend(_flat(f.message.fields, v, prefix + f.name + "_"))
        else:
            out.append((prefix + f.name, f, v))
    return out


def _as_int(f, v):
    # an integer a ROS message field would hold: steps of the resolution
    if isinstance(f, Fixed):
        x = v / f.res
        return int(x + 0.5) if x >= 0 else -int(-x + 0.5)
    if isinstance(f, UInt):
        return v
    raise TypeError("no integer form for %r" % (f.name,))


# --- cbor (rmw_desert) -------------------------------------------------------


class Cbor:
    name = "cbor"

    def __init__(self):
        self.cbor2 = importlib.import_module("cbor2")
        self._h = bytes(RMW_DESERT_HEADER)

    def prepare(self, item_name, item):
        # -> the value the peer's encoder takes for this item
        if item_name == "log":
            return zlib.compress(item, 9)
        msg, values = item[1], item[2]
        return [v if isinstance(f, Text6) else _as_int(f, v) for _, f, v in _flat(msg.fields, values)]

    def encode(self, item_name, value):
        return self._h + self.cbor2.dumps(value)

    def decode(self, item_name, data):
        v = self.cbor2.loads(data[RMW_DESERT_HEADER:])
        return zlib.decompress(v) if item_name == "log" else v


# --- ltcodecs (ros_acomms) ---------------------------------------------------


class Ltcodecs:
    name = "ltcodecs"

    def __init__(self):
        self.lt = importlib.import_module("ltcodecs")
        self.bitstring = importlib.import_module("bitstring")
        self._codecs = {}
        self._h = bytes((LTCODECS_ID,))

    def _config(self, msg, values):
        cfg = {}
        for name, f, _ in _flat(msg.fields, values):
            if isinstance(f, Fixed):
                cfg[name] = {"codec": "linspace_float", "min_value": f.lo, "max_value": f.hi, "num_values": f.steps + 1}
            elif isinstance(f, UInt):
                cfg[name] = {"codec": "integer", "min_value": f.lo, "max_value": f.hi}
            elif isinstance(f, Text6):
                cfg[name] = {"codec": "string", "max_length": f.max_chars, "bits_per_char": 7}
            else:
                raise TypeError("no ltcodecs field for %r" % (name,))
        return cfg

    def prepare(self, item_name, item):
        if item_name == "log":
            n = len(item)
            lz = self.lt.DictCodec({"log": {"codec": "lzma", "max_length": n}})
            txt = self.lt.DictCodec({"log": {"codec": "string", "max_length": n, "bits_per_char": 7}})
            a = len(lz.encode({"log": item})[0].tobytes())
            b = len(txt.encode({"log": item.decode()})[0].tobytes())
            self._codecs[item_name] = lz if a <= b else txt
            return {"log": item if a <= b else item.decode()}
        msg, values = item[1], item[2]
        self._codecs[item_name] = self.lt.DictCodec(self._config(msg, values))
        return {name: v for name, _, v in _flat(msg.fields, values)}

    def encode(self, item_name, value):
        bits, _ = self._codecs[item_name].encode(value)
        return self._h + bits.tobytes()

    def decode(self, item_name, data):
        return self._codecs[item_name].decode(self.bitstring.ConstBitStream(bytes=data[LTCODECS_HEADER:]))


# --- IMC (imcpy) -------------------------------------------------------------


class Imc:
    # The closest IMC message(s) per item. IMC has no diver, PlaDyPos or
    # hull-state message of its own: a system's navigation goes out as
    # EstimatedState, a USBL fix of another system as UsblPosition, and
    # temperature, battery and voltage as one scalar message each; a packet
    # carries one message, so an item may take several packets.
    name = "imc"

    def __init__(self):
        self.imc = importlib.import_module("imcpy")

    def _msg(self, cls, **fields):
        m = getattr(self.imc, cls)()
        for k in fields:
            setattr(m, k, fields[k])
        m.src, m.dst = 0x2002, 0x2001
        return m

    def prepare(self, item_name, item):
        # -> a list of imcpy messages (serialized by encode)
        if item_name == "log":
            return [self._msg("TextMessage", origin="", text=item.decode())]
        v = item[2]
        if item_name == "teleop":
            # six-axis force/torque: x y z k m n, normalised thrust
            return [self._msg("DesiredControl", x=v["surge"], y=v["sway"], z=v["heave"], k=v["roll"], m=v["pitch"],
                              n=v["yaw"], flags=0x3F)]
        if item_name == "diver":
            return [self._msg("EstimatedState", psi=v["heading"] * 0.017453292519943295, depth=v["depth"])]
        if item_name == "pladypos":
            return [
                self._msg("EstimatedState", x=v["pladypos"]["x"], y=v["pladypos"]["y"],
                          psi=v["course"] * 0.017453292519943295, u=v["speed"]),
                self._msg("UsblPosition", target=0x2003, x=v["diver"]["x"], y=v["diver"]["y"]),
            ]
        if item_name == "vstate":
            return [self._msg("Temperature", value=v["temperature"]), self._msg("FuelLevel", value=v["battery"]),
                    self._msg("Voltage", value=v["voltage"])]
        if item_name == "chat":
            return [self._msg("TextMessage", origin="", text=v["text"])]
        raise KeyError(item_name)

    def encode_all(self, item_name, msgs):
        # -> [packet bytes, ...]
        return [m.serialize() for m in msgs]

    def encode(self, item_name, msgs):
        return b"".join(self.encode_all(item_name, msgs))

    def decode(self, item_name, data):
        # packets back to back: each one's size is in its header (payload
        # size at bytes 4..5, little-endian as DUNE sends)
        out = []
        i = 0
        while i < len(data):
            n = 20 + (data[i + 4] | data[i + 5] << 8) + 2
            out.append(self.imc.Packet.deserialize(data[i:i + n]))
            i += n
        return out


CLASSES = {"imc": Imc, "cbor": Cbor, "ltcodecs": Ltcodecs}


def peers():
    # -> {name: peer} for the peers that import
    gone = missing()
    return {p: CLASSES[p]() for p in PEERS if p not in gone}


def item_values():
    # -> {item: what compare_items gives the peers}: the message items and
    # the log's bytes
    d = dict(ci.message_items())
    d["log"] = ci.log_text()
    return d


def peer_bytes(peer):
    # -> {item: bytes on the wire} for one peer
    vals = item_values()
    return {name: len(peer.encode(name, peer.prepare(name, vals[name]))) for name in ci.ITEMS}
