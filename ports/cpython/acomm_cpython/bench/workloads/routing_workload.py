# `acomm bench routing`: multi-hop routing in the simulated ocean (issue 36),
# the real stack on seed 004's BPSK packet modem (acomm_sim.routednet has
# the scenarios, the flows and what is measured). Each scenario runs with
# seeds 1..5 in three ways: learned routes (acomm's route discovery),
# flooding every packet, and an oracle that knows the shortest path from
# the simulator's geometry. Figures per scenario and way (the learned ones
# without a suffix, the others with _flooding and _oracle):
#
#   routing_pdr_<s>                     packets delivered / sent, all seeds
#   routing_latency_p50_ms_<s>, _p95_   send to delivery, all seeds' packets
#   routing_overhead_ratio_<s>          route control bytes on the air
#                                       (modem framing included) / payload
#                                       bytes delivered, over the whole run
#   routing_overhead_ratio_steady_<s>   the same over the second half of the
#                                       traffic, once routes are known
#   routing_pdr_vs_oracle_<s>           learned PDR / the oracle's
#   routing_recovery_s_partition_death  relay dies: to the first transfer
#                                       frame on the way round (mean of seeds)
#   routing_recovery_s_partition_return relay is back: to the first transfer
#                                       frame through it again (mean of the
#                                       seeds where that happened; _returned
#                                       counts them)
#   routing_*_large_<n>                 the same figures for `large` at 256
#                                       and 1,024 nodes (one seed, all three
#                                       ways), so its PDR stands beside its
#                                       oracle's too
#   routing_sim_speedup_<n>_nodes       simulated / wall seconds, `large`
#                                       with learned routes, building the
#                                       network included
#   routing_sim_cost_growth_64_to_256   wall seconds per simulated second at
#                                       256 nodes over the same at 64 (random)
#   routing_sim_cost_growth_256_to_1024 the same, 1,024 nodes over 256
#
# A figure with no value (nothing delivered, no recovery seen) is not
# printed; stderr says which. --quick: the chain and the partition, one
# seed, a few minutes each (the figures mean nothing).
import sys
import time

from acomm_sim.routednet import MODES, RoutedNet

PER_RUNTIME = ()
SEEDS = (1, 2, 3, 4, 5)
MINUTES = {"chain": 40, "grid": 40, "random": 40, "partition": 40, "large": 20}
LARGE_NODES = (256, 1024)  # node ids from 256 up take 3 bytes on the water (acomm.frame.addr_bytes)


def _quantile(xs, q):
    if not xs:
        return None
    xs = sorted(xs)
    k = int(q * len(xs) + 0.5) - 1
    return xs[min(len(xs) - 1, max(0, k))]


def _scenario(scenario, mode, seeds, minutes, nodes=None):
    """All seeds of one scenario and way -> (pooled figures, wall s, simulated s)."""
    sent = got = 0
    lat = []
    ctl = ctl_steady = pay = pay_steady = 0
    deaths, returns = [], []
    wall = sim = 0.0
    for seed in seeds:
        t0 = time.monotonic()
        net = RoutedNet(scenario, mode, seed, nodes=nodes)
        m = net.run(minutes)
        wall += time.monotonic() - t0
        sim += net.w.now() / 1000.0
        sent += m["sent"]
        got += m["delivered"]
        lat += list(net.got.values())
        ctl += net.control_bytes
        pay += net.delivered_bytes
        ctl_steady += m["steady_control_bytes"]
        pay_steady += m["steady_delivered_bytes"]
        if m.get("recovery_death_s") is not None:
            deaths.append(m["recovery_death_s"])
        if m.get("recovery_return_s") is not None:
            returns.append(m["recovery_return_s"])
    out = {
        "pdr": got / sent if sent else None,
        "latency_p50_ms": _quantile(lat, 0.5),
        "latency_p95_ms": _quantile(lat, 0.95),
        "overhead_ratio": ctl / pay if pay else None,
        "overhead_ratio_steady": ctl_steady / pay_steady if pay_steady else None,
    }
    if scenario == "partition" and mode != "flooding":  # flooding moves no transfer frames
        out["recovery_death"] = sum(deaths) / len(deaths) if deaths else None
        out["recovery_return"] = sum(returns) / len(returns) if returns else None
        out["returned"] = len(returns)
    return out, wall, sim


def run(emit, quick=False):
    def put(name, value, unit):
        if value is None:
            print("acomm bench routing: %s: no value (nothing to measure it on)" % name, file=sys.stderr)
        else:
            emit(name, round(value, 4) if isinstance(value, float) else value, unit)

    scenarios = ("chain", "partition") if quick else ("chain", "grid", "random", "partition")
    seeds = SEEDS[:1] if quick else SEEDS
    cost = {}
    for s in scenarios:
        minutes = 8 if quick else MINUTES[s]
        res = {}
        for mode in MODES:
            res[mode], wall, sim = _scenario(s, mode, seeds, minutes)
            if mode == "learned":
                cost[s] = wall / sim
        _put_all(put, s, res)
    # the simulator as networks grow: `large` at each of LARGE_NODES, one seed, all three ways
    # (learned routes' PDR beside the oracle's as for the other scenarios); speed from the
    # learned run
    minutes = 4 if quick else MINUTES["large"]
    before = ("random", 64)
    for n in (40,) if quick else LARGE_NODES:
        res = {}
        for mode in MODES:
            res[mode], w, sm = _scenario("large", mode, (1,), minutes, nodes=n)
            if mode == "learned":
                cost[n] = w / sm
        _put_all(put, "large_%d" % n, res)
        put("routing_sim_speedup_%d_nodes" % n, 1 / cost[n], "x real time")
        if before[0] in cost:
            put("routing_sim_cost_growth_%d_to_%d" % (before[1], n), cost[n] / cost[before[0]], "ratio")
        before = (n, n)


def _put_all(put, s, res):
    # one scenario's figures, each way (s: the scenario's name in the figures)
    for mode in MODES:
        r = res[mode]
        suffix = s if mode == "learned" else "%s_%s" % (s, mode)
        put("routing_pdr_" + suffix, r["pdr"], "ratio")
        put("routing_latency_p50_ms_" + suffix, r["latency_p50_ms"], "ms")
        put("routing_latency_p95_ms_" + suffix, r["latency_p95_ms"], "ms")
        put("routing_overhead_ratio_" + suffix, r["overhead_ratio"], "ratio")
        put("routing_overhead_ratio_steady_" + suffix, r["overhead_ratio_steady"], "ratio")
        if "recovery_death" in r:
            tail = "" if mode == "learned" else "_" + mode
            put("routing_recovery_s_partition_death" + tail, r["recovery_death"], "s")
            put("routing_recovery_s_partition_return" + tail, r["recovery_return"], "s")
            put("routing_recovery_partition_returned" + tail, r["returned"], "seeds")
    o = res["oracle"]["pdr"]
    put("routing_pdr_vs_oracle_" + s, res["learned"]["pdr"] / o if o else None, "ratio")
