# BENCHMARKS.md is in step with `acomm bench compare`: its text
# is what the generator renders from the figures it keeps, and the figures
# that do not depend on timing (bytes, limits, ratios, airtime) are what the
# code computes today. Timings are never checked. Peers that are not
# installed (the `bench` extra is not in `dev`) have their figures skipped.
import os

import pytest

from acomm_cpython.bench import benchmarks_md as bm
from acomm_cpython.bench.workloads import compare_items as ci
from acomm_cpython.bench.workloads import compare_peers as cp
from acomm_cpython.bench.workloads import compare_workload as cw

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATH = os.path.join(ROOT, "BENCHMARKS.md")


def _kept():
    with open(PATH) as f:
        text = f.read()
    return text, bm.figures_of(text)


def test_text_is_what_the_generator_renders_from_its_figures():
    text, (records, machine) = _kept()
    assert bm.render(records, machine) == text, "regenerate: .venv/bin/python tools/mkbenchmarks.py --render-only"


def test_static_figures_match_the_code():
    _, (records, _) = _kept()
    kept = {r[0]: r for r in records}
    fresh = cw.static_records(cp.peers())
    assert fresh
    for name, value, unit in fresh:
        assert name in kept, "%s missing from BENCHMARKS.md: regenerate it" % name
        assert kept[name][1:] == (value, unit), (name, kept[name], value)
    # every peer's rows were measured for the committed file
    for p in cp.PEERS:
        assert "bytes_teleop_" + p in kept


def test_acomm_bytes_are_what_the_frames_hold():
    # the elided and raw forms are the frame module's own encodings
    items = ci.message_items()
    for name in ci.MESSAGE_ITEMS:
        p = ci.acomm_payload(items[name])
        e, r = ci.acomm_frames(p)
        assert len(e) == len(p) + 1 and len(r) == len(p) + 5
        assert items[name][0].unpack(p)[0][1] == items[name][2]
    n, wire = ci.log_frames(b"x" * 508)  # two fragments of 254 bytes
    assert (n, wire) == (2, 512)


def test_ltcodecs_gets_the_same_bits_as_acomm():
    # the comparison is fair only if ltcodecs' body is sized by the same
    # ranges: same bits, so the bytes differ only by headers and ids
    pytest.importorskip("ltcodecs")
    lt = cp.Ltcodecs()
    items = ci.message_items()
    for name in ("teleop", "diver", "pladypos", "vstate"):
        cat, msg, values = items[name]
        codec = lt.lt.DictCodec(lt._config(msg, values))
        bits, _ = codec.encode(lt.prepare(name, items[name]))
        assert len(bits) == msg.max_bits, name


def test_cbor_command_matches_seed_004():
    # rmw_desert put the seed's six-integer command in 13-14 bytes
    pytest.importorskip("cbor2")
    c = cp.Cbor()
    item = ci.message_items()["teleop"]
    assert 13 <= len(c.encode("teleop", c.prepare("teleop", item))) <= 14
