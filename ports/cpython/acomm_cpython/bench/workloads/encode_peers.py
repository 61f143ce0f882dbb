# CPython only: acomm's encode + decode against the compare peers that are
# installed (cbor2 as rmw_desert sends it, ltcodecs as ros_acomms does),
# timed as compare_workload times them (batches interleaved in one process
# in an order that rotates every round), but each coder's figure is its
# fastest round: on a machine shared with other work the median moved by a
# factor of 3 from run to run, the fastest round by a few per cent.
from acomm_cpython.bench.workloads import compare_peers as cp
from acomm_cpython.bench.workloads.compare_workload import ROUNDS, _PeerCoder, time_rounds

PEERS = ("cbor", "ltcodecs")


def peer_ratios(items, ours, rounds=ROUNDS, warm=3000):
    # -> [(name, peer rate / acomm rate, unit)] per item and installed peer
    peers = {k: v for k, v in cp.peers().items() if k in PEERS}
    out = []
    for name in items:
        coders = {"acomm": ours[name]}
        for p in sorted(peers):
            try:
                coders[p] = _PeerCoder(peers[p], name, peers[p].prepare(name, items[name]))
            except TypeError:  # a field kind the peer has no codec for
                continue
        for c in coders:  # warm up (CPython specialises code that runs often)
            for _ in range(warm):
                coders[c].decode(coders[c].encode())
        per = time_rounds(coders, rounds)
        base = min(per["acomm"])
        for p in list(coders)[1:]:
            out.append(("encode_decode_%s_over_acomm_%s" % (p, name), round(base / min(per[p]), 3), "x acomm"))
    return out
