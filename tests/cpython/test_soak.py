# A short soak (acomm_cpython.bench.workloads.soak_workload): the demo network,
# routing on, for 1.5 simulated hours with every fault kind at 12 times the 24-hour
# run's rate, then drained. Every accepted packet must end delivered or
# reported expired/failed, none delivered twice or damaged, no exception
# may escape a node's step, and every fault kind must really have happened.
# Acknowledged sealed commands go between the nodes meanwhile: none may be
# carried out twice.
from acomm_cpython.bench.workloads.soak_workload import RATES, soak


def test_short_soak_loses_nothing_and_every_fault_happened():
    f, wall, s = soak(seed=3, hours=1.5, rate_scale=12, trace=False)
    assert f["packets_accepted"] > 50
    assert f["packets_delivered"] > 20
    assert f["packets_lost"] == 0, f
    assert f["duplicates_delivered"] == 0, f
    assert f["packets_corrupt"] == 0 and f["extra_final_statuses"] == 0, f
    assert f["task_deaths"] == 0, s.deaths
    assert f["packets_pending_at_end"] == 0
    assert f["route_requests"] > 0  # routed: the nodes searched for each other when the faults cut them off
    for kind in RATES:
        assert f["faults_" + kind] > 0, kind
    assert f["packets_refused_store_full"] > 0 and f["stores_filled"] > 0
    # a power loss rebuilds one node, a restart in the middle of a transfer or command both ends
    assert f["faults_power_loss"] + f["faults_restart_pair"] < s.rebuilt <= f["faults_power_loss"] + 2 * f["faults_restart_pair"]
    # sealed commands resent by the link for up to 10 minutes, through restarts of both ends:
    # none carried out twice, none reported delivered that its host never had (but for a SeaTrac
    # acknowledging by itself while its host's cable was out)
    assert f["commands_sent"] > 10 and f["commands_executed_twice"] == 0 and f["commands_lost"] == 0, f
    assert f["commands_without_status"] == 0, f
    # a GPS glitch of an hour to a day is never taken by a clock that has had a good fix
    assert f["clock_bad_fixes_offered"] > 0 and f["clock_bad_fixes_taken"] == 0, f
    assert sum(c.errors_raised for c in s.cables.values()) > 0  # unplugs that raised
    assert s.channel.noise_lost > 0
    assert sum(wc.jumps for wc in s.walls.values()) == f["faults_clock_jump"]
