# `acomm bench attack`, shortened: an attacker without the key in the demo's
# ocean for 12 simulated minutes, the AUV's clock jump at minute 5 and its
# restart at minute 8, two idle hours after the drain (the world skips them;
# then the commands of the first 6 minutes are replayed), packets that
# live 15 minutes (the drain lasts until they are settled, and the attacker
# goes on through it: about 30 simulated minutes in all, the bench's hour
# takes 100). In
# strict mode (the default with a key) none of its attacks succeeds, route
# poisoning and flood amplification included, and the legitimate packets all
# arrive once; in open mode forged SACKs and forged route control succeed,
# which is what the bench is there to show.
from acomm_cpython.bench.workloads.attack_workload import KINDS, Attack

ROUTE_KINDS = [k for k in KINDS if k.startswith("route_")]


def _figures(strict):
    a = Attack(strict=strict, minutes=12, lifespan_s=900, restart_ms=8 * 60000, jump_ms=5 * 60000,
               early_ms=6 * 60000)
    try:
        a.run()
        return a.figures()
    finally:
        a.close()


def test_strict_mode_stops_every_attack_and_loses_nothing():
    f = _figures(True)
    for k in KINDS:
        # route control is on file before a node acts on it, as commands are: no restart makes a
        # recording of it fresh again (docs/wire-format.md)
        assert f["attack_%s_succeeded" % k] == 0, (k, f)
    assert sum(f["attack_%s_tries" % k] for k in KINDS) > 300
    for k in ROUTE_KINDS + ["replay_after_restart", "replay_after_clock_jump", "replay_after_hours"]:
        assert f["attack_%s_tries" % k] > 0, (k, f)
    assert f["attack_route_request_flood_amplification"] == 0 and f["attack_route_flood_amplification"] == 0
    assert f["attack_route_floods_handed"] == 0 and f["attack_routes_via_attacker"] == 0
    assert f["attack_legit_route_control_sent"] > 0  # the nodes routed: there were routes to aim at
    assert f["attack_legit_packets_accepted"] > 10
    assert f["attack_legit_packets_lost"] == 0 and f["attack_legit_packets_duplicated"] == 0
    assert f["attack_legit_commands_lost"] == 0 and f["attack_legit_commands_duplicated"] == 0
    assert f["attack_refused_sack"] > 0 and f["attack_refused_flood"] > 0 and f["attack_refused_route"] > 0


def test_open_mode_lets_forged_sacks_and_routes_through():
    f = _figures(False)
    assert f["attack_sack_refusal_succeeded"] > 0 and f["attack_sack_bitmap_succeeded"] > 0
    assert f["attack_route_reply_succeeded"] > 0 and f["attack_route_request_flood_succeeded"] > 0
    assert f["attack_route_request_flood_amplification"] > 0
    assert not [k for k in f if k.startswith("attack_refused_")]
