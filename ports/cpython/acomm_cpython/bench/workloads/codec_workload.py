# Codec figures: how close each catalog message comes to its information
# content, and how fast a message encodes and decodes. Portable: runs
# in-process on CPython and as a script on the MicroPython unix port.
#
#   run(emit) calls emit(name, value, unit) for:
#     bits_<catalog>_<message>        worst-case encoded bits, the catalog id
#                                     included, before any framing
#     limit_bits_<catalog>_<message>  log2 of the number of distinct values
#                                     of the body, plus log2 of the number of
#                                     messages in the catalog (what the id
#                                     tells)
#     bits_packed_workload            one teleop thrust command + one CADDY
#                                     diver reply + one PlaDyPos reply + one
#                                     20-character chat line, each id + body,
#                                     packed back to back per catalog (bits
#                                     before the final byte padding)
#     limit_bits_packed_workload      the same content's information: each
#                                     message's limit, except the chat line,
#                                     which is 20 symbols of 42 plus which of
#                                     the 0..max lengths it has
#     encodes_per_s                   encode + decode of one PlaDyPos reply,
#                                     per second (per runtime)
#
# Catalogs are those of acomm.catalog.MODULES that import; a set that does
# not exist yet is left out, and the teleop part of the packed workload with
# it.

import math

try:
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv, rate, set_quick
except ImportError:  # MicroPython: the runner puts this folder on the path
    from timer import emit_json, quick_argv, rate, set_quick

from acomm.codec.bits import BitReader, BitWriter
from acomm.catalog import MODULES, load
from acomm.codec.text6 import Text6

PER_RUNTIME = ("encodes_per_s",)

CHAT_LINE = "need air, ascending!"  # 20 characters


def _catalogs():
    out = {}
    for name in MODULES:
        try:
            out[name] = load(name)
        except ImportError:
            pass
    return out


def _example(m):
    # A valid value dict for any message: the body decoded from zero bits
    # (code 0 is valid for every field kind).
    return m.decode_from(BitReader(bytes((m.max_bits + 7) >> 3)))


def _chat_limit(cat, m, text):
    f = m.fields[0]
    assert isinstance(f, Text6)
    return cat.id_limit_bits + len(text) * math.log2(42) + math.log2(f.max_chars + 1)


def packed(cats):
    # Returns (bits, limit_bits) of the packed workload.
    caddy = cats["caddy"]
    reply = caddy["pladypos_reply"]
    items = [
        (caddy["diver_reply"], {"heading": 123.4, "depth": 17.5}),
        (
            reply,
            {
                "quant": 0,
                "pladypos": {"x": 12.3, "y": -4.5},
                "course": 270.0,
                "speed": 0.6,
                "diver": {"x": -20.0, "y": 33.3},
            },
        ),
        (caddy["chat"], {"text": CHAT_LINE}),
    ]
    w = BitWriter(bytearray(64))
    caddy.pack_into(w, items)
    bits = w.bit_length
    limit = caddy.limit_bits("diver_reply") + caddy.limit_bits(reply) + _chat_limit(caddy, caddy["chat"], CHAT_LINE)
    teleop = cats.get("teleop")
    if teleop is not None:
        thrust = teleop["thrust"]
        w = BitWriter(bytearray(64))
        teleop.pack_into(w, [(thrust, _example(thrust))])
        bits += w.bit_length
        limit += teleop.limit_bits(thrust)
    return bits, limit


def run(emit, quick=False):
    set_quick(quick)
    cats = _catalogs()
    for name in cats:
        cat = cats[name]
        for m in cat.messages:
            emit("bits_%s_%s" % (name, m.name), cat.bits(m), "bit")
            emit("limit_bits_%s_%s" % (name, m.name), round(cat.limit_bits(m), 2), "bit")
    if "caddy" in cats:
        bits, limit = packed(cats)
        emit("bits_packed_workload", bits, "bit")
        emit("limit_bits_packed_workload", round(limit, 2), "bit")

        reply = cats["caddy"]["pladypos_reply"]
        values = _example(reply)
        buf = bytearray((reply.max_bits + 7) >> 3)
        w = BitWriter(buf)

        def roundtrips():
            for _ in range(20):
                w.reset()
                reply.encode_into(w, values)
                got = reply.decode_from(BitReader(buf))
            assert got["quant"] == values["quant"]
            return 20

        emit("encodes_per_s", int(rate(roundtrips)), "1/s")


if __name__ == "__main__":
    run(emit_json, quick_argv())
