# The Seaware AUV control set (seed 002, section III.A, Table I) and the
# compact packet that carries it over Benthos modems (section II.B.2).
#
# Table I's payload sizes include the packet's 1-byte header and 2-byte CRC
# and the message's 1-byte tag, so a request of 4 bytes has no data and the
# Mission State and Vehicle State replies carry 15 and 3 bytes of data. The
# catalog uses 8-bit ids (the tags) and replies are request + 128; every
# body is exactly its table size, so encode() gives the table's byte counts.
# The paper names what those data bytes hold but not their layout: the
# fields below are acomm's choice, filling each budget exactly (120 and 24
# bits); docs/catalogs.md gives the reasons.
#
# Compact packet: header = 7-bit sender address (MSB first) then the
# compressed flag in bit 0; payload; CRC-16/ARC of header + payload,
# big-endian. The paper fixes only the sizes; the bit order, CRC variant and
# byte order follow acomm's own frame (docs/catalogs.md).

from ..codec.fields import Enum, Fixed, UInt
from ..codec.message import Catalog, Message
from ..compat import const
from ..codec.crc import crc16
from ..errors import CRCError, DecodeError, EncodeError

MAX_ADDR = const(127)
OVERHEAD = const(3)  # header + CRC
REPLY = const(128)  # reply tag = request tag + 128

START_MISSION = Message("start_mission", 0, ())
STOP_MISSION = Message("stop_mission", 1, ())
GET_MISSION_STATE = Message("get_mission_state", 2, ())
GET_VEHICLE_STATE = Message("get_vehicle_state", 3, ())
RENDEZVOUS_ON = Message("rendezvous_on", 4, ())
RENDEZVOUS_OFF = Message("rendezvous_off", 5, ())

START_MISSION_ACK = Message("start_mission_ack", 128, ())
STOP_MISSION_ACK = Message("stop_mission_ack", 129, ())
# 15 data bytes = 120 bits: completion status, position, velocity, leg.
# Latitude and longitude are integer micro-degrees (0.11 m): a 28/29-bit
# step count does not survive the single-precision floats of MCU ports.
MISSION_STATE = Message(
    "mission_state",
    130,
    (
        Enum("status", ("idle", "executing", "completed", "aborted")),  # 2
        UInt("completion", 0, 100),  # 7: percent of the mission done
        UInt("leg", 0, 255),  # 8: current mission leg (maneuver)
        UInt("lat_udeg", -90000000, 90000000),  # 28
        UInt("lon_udeg", -180000000, 180000000),  # 29
        Fixed("depth", 0, 409.5, 0.1),  # 12: metres
        Fixed("vel_n", -4.095, 4.095, 0.002),  # 12: m/s north
        Fixed("vel_e", -4.095, 4.095, 0.002),  # 12: m/s east
        Fixed("vel_d", -1.023, 1.023, 0.002),  # 10: m/s down
    ),
)
# 3 data bytes = 24 bits: internal temperature and battery.
VEHICLE_STATE = Message(
    "vehicle_state",
    131,
    (
        Fixed("temperature", -20, 107.5, 0.5),  # 8: degrees C inside the hull
        UInt("battery", 0, 100),  # 7: percent of charge remaining
        Fixed("voltage", 0, 51.1, 0.1),  # 9: battery volts
    ),
)
RENDEZVOUS_ON_ACK = Message("rendezvous_on_ack", 132, ())
RENDEZVOUS_OFF_ACK = Message("rendezvous_off_ack", 133, ())
INVALID_CRC = Message("invalid_crc", 255, ())

REQUESTS = (START_MISSION, STOP_MISSION, GET_MISSION_STATE, GET_VEHICLE_STATE, RENDEZVOUS_ON, RENDEZVOUS_OFF)
REPLIES = (
    START_MISSION_ACK,
    STOP_MISSION_ACK,
    MISSION_STATE,
    VEHICLE_STATE,
    RENDEZVOUS_ON_ACK,
    RENDEZVOUS_OFF_ACK,
    INVALID_CRC,
)
CATALOG = Catalog("seaware", id_bits=8, messages=REQUESTS + REPLIES)
BY_NAME = {m.name: m for m in REQUESTS + REPLIES}
# request name -> its reply message
REPLY_OF = {q.name: REPLIES[i] for i, q in enumerate(REQUESTS)}


def encode_packet(src, payload, compressed=False):
    # The compact packet around an already encoded payload.
    if not 0 <= src <= MAX_ADDR:
        raise EncodeError("seaware packet: sender address %d outside 0..%d" % (src, MAX_ADDR))
    n = len(payload)
    buf = bytearray(n + OVERHEAD)
    buf[0] = (src << 1) | (1 if compressed else 0)
    buf[1 : n + 1] = payload
    c = crc16(memoryview(buf)[: n + 1])
    buf[n + 1] = c >> 8
    buf[n + 2] = c & 0xFF
    return bytes(buf)


def decode_packet(data):
    # -> (sender address, compressed flag, payload bytes).
    # DecodeError when too short, CRCError when the CRC does not match.
    n = len(data)
    if n < OVERHEAD:
        raise DecodeError("seaware packet: %d bytes, shorter than the minimum %d" % (n, OVERHEAD))
    want = (data[n - 2] << 8) | data[n - 1]
    got = crc16(memoryview(data)[: n - 2])
    if want != got:
        raise CRCError("seaware packet: CRC 0x%04x does not match computed 0x%04x" % (want, got))
    h = data[0]
    return h >> 1, bool(h & 1), bytes(data[1 : n - 2])


def encode(src, msg, values=None):
    # One control message in its compact packet (the sizes of Table I).
    if isinstance(msg, str):
        msg = BY_NAME[msg]
    return encode_packet(src, CATALOG.pack([(msg, values or {})]))


def decode(data):
    # -> (sender address, Message, values). Seaware sends one message per
    # packet; anything else, and compressed payloads (acomm implements no
    # Seaware compression), raise DecodeError.
    src, compressed, payload = decode_packet(data)
    if compressed:
        raise DecodeError("seaware packet: compressed payloads are not supported")
    if not payload:
        raise DecodeError("seaware packet: no message tag")
    msgs = CATALOG.unpack(payload)
    if len(msgs) != 1:
        raise DecodeError("seaware packet: %d messages, expected 1" % len(msgs))
    m, v = msgs[0]
    return src, m, v


def invalid_crc_reply(src):
    # What a peer sends back when a packet failed its CRC (tag 255).
    return encode(src, INVALID_CRC)
