# Seed 004's teleoperation replay (acomm bench teleop): latency follows the
# modem profiles' airtime and the propagation delay, and acomm's encoding
# puts fewer bytes on the modem than the seed's 14.
from acomm_cpython.bench.workloads import teleop_workload as tw


def test_latency_follows_airtime_and_acomm_is_smaller(monkeypatch):
    monkeypatch.setattr(tw, "CYCLES", 2)
    paper = tw.run_config("bpsk", 0.6, "paper")
    assert paper["sent"] == 16 and paper["pdr"] == 100.0 and paper["bytes_on_modem"] == 14
    # (14 + 12) bytes at 400 bit/s = 520 ms, seen in 10 ms steps
    assert 520 <= paper["latency_median_ms"] <= 540
    ours = tw.run_config("bpsk", 0.6, "acomm")
    assert ours["bytes_on_modem"] == 10 and ours["latency_median_ms"] < paper["latency_median_ms"]
    far = tw.run_config("fhss", 85.0, "paper")
    # (14 + 10) bytes at 192 bit/s = 1000 ms, plus 57 ms over 85 m
    assert 1057 <= far["latency_median_ms"] <= 1080


def test_river_pdr_stays_inside_the_seed_trials():
    # the calibration: a change to the channel or the generator that moves
    # the simulated 85 m PDR out of seed 004's river trials must show here
    for profile in ("bpsk", "fhss"):
        t1, t2 = tw.SEED[("river", profile)][0]
        got = tw.run_config(profile, 85.0, "acomm")["pdr"]
        assert min(t1, t2) <= got <= max(t1, t2), (profile, got, t1, t2)
