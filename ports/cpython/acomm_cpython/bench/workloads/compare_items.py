# The fixed workload of `acomm bench compare` and acomm's side of
# it: six things a vehicle, a diver or an operator sends, each with the
# acomm message that carries it, its information limit, and acomm's bytes
# in each frame form. Portable (acomm only): compare_speed runs it under the
# MicroPython unix port too. The peers' encodings of the same values are in
# compare_peers (CPython only).
#
#   teleop     seed 004's six-axis thrust command (teleop catalog)
#   diver      a CADDY diver reply to a USBL ping: heading, depth (seed 003)
#   pladypos   a CADDY PlaDyPos reply: its offset, course, speed, the
#              diver's offset (seed 003)
#   vstate     a Seaware Vehicle State reply: temperature, battery,
#              voltage (seed 002)
#   chat       a 20-character CADDY chat line
#   log        2 KiB of a diver computer's text log (divelog.py), sent as
#              one transport packet: compressed when that helps, fragmented

try:
    from acomm_cpython.bench.workloads.divelog import divelog
except ImportError:  # MicroPython: the runner puts this folder on the path
    from divelog import divelog

import math

from acomm.codec import compress
from acomm import frame
from acomm.transport import segment
from acomm.catalog import caddy, seaware, teleop

CHAT_LINE = "need air, ascending!"  # 20 characters
THRUST = (0.6, -0.2, 0.5, 0.0, 0.0, 0.13)  # surge sway heave roll pitch yaw
THRUST_SEQ = 5

# Message items: name -> (catalog, message, values). The values are those
# the codec gives back (already on its quantization grid), so every peer
# is handed exactly the information acomm carries.
MESSAGE_ITEMS = ("teleop", "diver", "pladypos", "vstate", "chat")
ITEMS = MESSAGE_ITEMS + ("log",)

# The log goes over a WHOI Micro-Modem at rate 5 (256-byte frames), a link
# that carries its own addressing and CRC: acomm's elided form.
LOG_MTU = 256
LOG_PID = 1


def _grid(cat, msg, values):
    # round-trip once, so the values are the decoded ones
    return cat.unpack(cat.pack([(msg, values)]))[0][1]


def message_items():
    # -> {name: (catalog, message, values)}
    out = {}
    out["teleop"] = (teleop.CATALOG, teleop.THRUST, teleop.thrust_values(THRUST, THRUST_SEQ))
    out["diver"] = (caddy.CATALOG, caddy.DIVER_REPLY, {"heading": 123.4, "depth": 17.5})
    out["pladypos"] = (caddy.CATALOG, caddy.PLADYPOS_REPLY, {
        "quant": 0, "pladypos": {"x": 12.3, "y": -4.5}, "course": 270.0, "speed": 0.6,
        "diver": {"x": -20.0, "y": 33.3}})
    out["vstate"] = (seaware.CATALOG, seaware.VEHICLE_STATE, {"temperature": 31.5, "battery": 76, "voltage": 25.2})
    out["chat"] = (caddy.CATALOG, caddy.CHAT, {"text": CHAT_LINE})
    for k in out:
        cat, msg, values = out[k]
        out[k] = (cat, msg, _grid(cat, msg, values))
    return out


def log_text():
    return divelog()


def limit_bits(name, item=None):
    # The information limit of the item's content: the sum over fields of
    # log2 of the number of distinct values (Message.limit_bits), except
    # the chat line, whose content is its 20 symbols of 42 and which of the
    # 0..40 lengths it has (not every length's strings), and the log, whose
    # reference is its size under zlib at level 9 (measured on CPython by
    # compare_peers; None here). Which message it is (the catalog id) is
    # not counted: limit_with_id_bits adds it.
    if name == "log":
        return None
    cat, msg, values = item
    if name == "chat":
        return len(values["text"]) * math.log2(42) + math.log2(caddy.CHAT_CHARS + 1)
    return msg.limit_bits


def limit_with_id_bits(name, item):
    # the limit plus log2 of the number of messages in the catalog: what
    # telling this message from its siblings is worth
    return limit_bits(name, item) + item[0].id_limit_bits


def acomm_payload(item):
    # the catalog's bytes for one message: id + body, padded to a byte
    cat, msg, values = item
    return cat.pack([(msg, values)])


def acomm_frames(payload):
    # -> (elided, raw): one DATA link frame in each form, src 2 -> dst 1
    elided = frame.encode_elided(frame.Frame(frame.DATA, 2, 1, 0, payload))
    raw = frame.encode_raw(frame.Frame(frame.DATA, 2, 1, 0, payload))
    return elided, raw


def log_packet(data):
    # The transport's packet for the log, as Transport.send builds it for a
    # neighbour: compressed when shorter, the packet header in front.
    body = compress.compress(data)
    compressed = len(body) < len(data)
    if not compressed:
        body = data
    return segment.packet_header(LOG_PID, len(body), compressed) + body


def log_frames(blob, mtu=LOG_MTU, overhead=frame.ELIDED_OVERHEAD):
    # -> (frames, bytes on the wire): fragments of at most mtu - the frame
    # header - the fragment index, each with both
    room = mtu - overhead - segment.FRAG_HEADER
    n = (len(blob) + room - 1) // room
    return n, len(blob) + n * (overhead + segment.FRAG_HEADER)


def acomm_bytes():
    # -> {item: {"payload": n, "elided": n, "raw": n, "frames": n}}
    out = {}
    items = message_items()
    for name in MESSAGE_ITEMS:
        p = acomm_payload(items[name])
        e, r = acomm_frames(p)
        out[name] = {"payload": len(p), "elided": len(e), "raw": len(r), "frames": 1}
    blob = log_packet(log_text())
    n, on_wire = log_frames(blob)
    raw_n, raw_wire = log_frames(blob, overhead=frame.RAW_OVERHEAD_SHORT)
    out["log"] = {"payload": len(blob), "elided": on_wire, "raw": raw_wire, "frames": n}
    return out
