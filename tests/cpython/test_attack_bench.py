# `acomm bench attack`, shortened: an attacker without the key in the demo's
# ocean for 12 simulated minutes. In strict mode (the default with a key)
# none of its attacks succeeds and the legitimate packets all arrive once;
# in open mode forged SACKs succeed, which is what the bench is there to show.
from acomm_cpython.bench.workloads.attack_workload import KINDS, Attack


def _figures(strict):
    a = Attack(strict=strict, minutes=12)
    try:
        a.run()
        return a.figures()
    finally:
        a.close()


def test_strict_mode_stops_every_attack_and_loses_nothing():
    f = _figures(True)
    for k in KINDS:
        assert f["attack_%s_succeeded" % k] == 0, (k, f)
    assert sum(f["attack_%s_tries" % k] for k in KINDS) > 300
    assert f["attack_legit_packets_accepted"] > 10
    assert f["attack_legit_packets_lost"] == 0 and f["attack_legit_packets_duplicated"] == 0
    assert f["attack_legit_commands_lost"] == 0 and f["attack_legit_commands_duplicated"] == 0
    assert f["attack_refused_sack"] > 0 and f["attack_refused_flood"] > 0


def test_open_mode_lets_forged_sacks_through():
    f = _figures(False)
    assert f["attack_sack_refusal_succeeded"] > 0 and f["attack_sack_bitmap_succeeded"] > 0
    assert not [k for k in f if k.startswith("attack_refused_")]
