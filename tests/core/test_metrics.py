# Run metrics (acomm_sim.metrics): PDR, latency statistics with bootstrap
# intervals, seed 004's jitter, and the CSV rows.
from acomm_sim.metrics import CSV_HEADER, PacketLog, bootstrap_ci, jitter, mean, median


def test_statistics_by_hand():
    assert median([5, 1, 3]) == 3 and median([4, 1, 3, 2]) == 2.5 and median([]) is None
    assert mean([1, 2, 6]) == 3 and mean([]) is None
    # J = mean |L_k - L_(k-1)|: |12-10| + |9-12| + |9-9| = 5 over 3
    assert abs(jitter([10, 12, 9, 9]) - 5 / 3) < 1e-12 and jitter([7]) is None
    lo, hi = bootstrap_ci([10, 11, 12, 13, 50], mean, 500, 2)
    assert 10 <= lo <= mean([10, 11, 12, 13, 50]) <= hi <= 50
    assert bootstrap_ci([3, 3, 3], median) == (3, 3) and bootstrap_ci([1], mean) is None


def test_log_summaries_and_csv():
    log = PacketLog(capacity=5)
    for i in range(6):
        log.sent(i, "teleop" if i % 2 else "telemetry", "acoustic", "buoy", "auv", 6 + i, 1000 * i)
    assert log.dropped == 1  # the sixth did not fit
    log.received(0, 1400)
    log.received(1, 2500)
    log.received(1, 2600)
    log.received(3, 3900)
    log.received(99, 1)
    assert log.duplicates == 1 and log.unknown == 1
    s = log.summary()
    assert s["sent"] == 5 and s["received"] == 3 and s["pdr"] == 0.6
    assert s["latency_median_ms"] == 1400 and s["jitter_ms"] == (100 + 600) / 2  # 1400, 1500, 900
    per = log.summaries()
    assert per[("teleop", "acoustic")]["pdr"] == 1.0 and per[("telemetry", "acoustic")]["received"] == 1
    lines = list(log.csv_lines())
    assert lines[0] == CSV_HEADER and len(lines) == 6
    assert lines[1] == "0,telemetry,acoustic,buoy,auv,6,0,1400,1400"
    assert lines[3] == "2,telemetry,acoustic,buoy,auv,8,2000,,"
