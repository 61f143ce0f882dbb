# The discovery benchmark workload: deterministic, and bounded by one advert
# period after the last node powers on (every node hears each other node's
# next advert within one period; the newcomer's own advert goes at once).

from acomm_cpython.bench.workloads import discovery_workload as dw


def test_discovery_within_one_period_and_deterministic():
    p = 4000
    times = [dw.discovery_ms(seed, period_ms=p) for seed in (1, 2, 3)]
    assert times == [dw.discovery_ms(seed, period_ms=p) for seed in (1, 2, 3)]
    for t in times:
        assert 0 <= t <= p + 100


def test_run_emits_both_figures():
    got = {}
    dw.run(lambda name, value, unit: got.__setitem__(name, (value, unit)))
    assert set(got) == {"discovery_time_s", "discovery_time_periods"}
    assert got["discovery_time_s"][1] == "s"
    assert 0 < got["discovery_time_periods"][0] <= 1.01
