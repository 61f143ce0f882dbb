# Workload for acomm.link.txqueue, portable to MicroPython and CPython.
#
#   run(emit) calls emit(name, value, unit) for:
#     queue_ops_per_s                   push + pop cycles per second with about
#                                       1000 requests queued, expire() every
#                                       100 cycles (requests are recycled, so
#                                       this measures the queue, not the
#                                       allocator)
#     alarm_latency_frames_under_flood  worst number of frames that went on the
#                                       air (counting the one already on the
#                                       air when the alarm arrived) before the
#                                       alarm was popped, over 100 alarms, with
#                                       a full queue of 10,000 class 10..16
#                                       requests. 1 is the best possible value.
#
# As a script it prints one JSON object per line:
#   python3 ports/cpython/acomm_cpython/bench/workloads/queue_workload.py
#   micropython ports/cpython/acomm_cpython/bench/workloads/queue_workload.py

import gc

try:
    from acomm_cpython.bench.workloads.timer import elapsed_us, emit_json, now_us, quick_argv
except ImportError:  # run as a script: this folder is on the path
    from timer import elapsed_us, emit_json, now_us, quick_argv

from acomm.compat import TICKS_MAX, ticks_add
from acomm.prng import Prng
from acomm.link.txqueue import PRIO_ALARM, TxQueue, TxRequest

# Only the throughput depends on the runtime; the latency is counted in
# frames on virtual time and comes out the same everywhere.
PER_RUNTIME = ("queue_ops_per_s",)


def _table(rng, n, lo, hi):
    return [rng.range(lo, hi) for _ in range(n)]


def bench_queue_ops(n_ops=20000, depth=1000):
    # Returns push+pop cycles per second.
    rng = Prng(7)
    prios = [(1, 2, 2, 3, 10, 10, 16, 16)[rng.below(8)] for _ in range(1024)]
    lifes = _table(rng, 1024, 2000, 120000)
    now = TICKS_MAX - 30000  # virtual time, in ticks; the run crosses the wrap
    q = TxQueue(2 * depth)
    pool = []
    rid = 0
    for _ in range(depth + 1):
        q.push(TxRequest(rid & 0xFFFF, 1, prios[rid & 1023], ticks_add(now, lifes[rid & 1023])), now)
        rid += 1
    t0 = now_us()
    for i in range(n_ops):
        now = ticks_add(now, 5)
        r = q.pop(now)
        if r is None:
            r = pool.pop() if pool else TxRequest(0, 1, 16, 0)
        r.req_id = rid & 0xFFFF
        r.priority = prios[rid & 1023]
        r.deadline = ticks_add(now, lifes[rid & 1023])
        rid += 1
        q.push(r, now)
        if i % 100 == 99:
            for r in q.expire(now):
                pool.append(r)
            # top up what expired so the depth stays about `depth`
            while len(q) < depth and pool:
                r = pool.pop()
                r.priority = prios[rid & 1023]
                r.deadline = ticks_add(now, lifes[rid & 1023])
                rid += 1
                q.push(r, now)
    dt = elapsed_us(t0)
    return n_ops * 1e6 / dt


def bench_alarm_latency(n_alarms=100, flood=10000, aging_ms=0, prio=PRIO_ALARM):
    # Returns the worst number of frames on the air before an alarm (a request
    # of class `prio`) left the queue, the frame on the air when it arrived
    # included. aging_ms > 0 turns on the queue's fairness aging.
    rng = Prng(11)
    now = TICKS_MAX - 100000  # virtual time, in ticks
    q = TxQueue(flood, aging_ms)
    rid = 0
    for _ in range(flood):
        q.push(TxRequest(rid & 0xFFFF, 1, rng.range(10, 16), ticks_add(now, 3600000)), now)
        rid += 1
    spare = []
    alarm = None
    count = 0
    worst = 0
    done = 0
    frame = q.pop(now)  # the first frame goes on the air
    while done < n_alarms:
        spare.append(frame)
        airtime = rng.range(500, 3000)  # a 16..96 byte frame at 256 bit/s
        if alarm is None and rng.chance(0.3):
            at = rng.below(airtime)
            now = ticks_add(now, at)
            alarm = TxRequest(0xFFFF, 0, prio, ticks_add(now, 30000), b"SOS")
            out = q.push(alarm, now)
            if out is alarm:
                raise AssertionError("alarm refused")
            if out is not None:
                spare.append(out)  # a flood request evicted to make room
            count = 1  # the frame already on the air
            now = ticks_add(now, airtime - at)
        else:
            now = ticks_add(now, airtime)
        for r in q.expire(now):
            if r is alarm:
                # never sent: count what went on the air while it waited
                worst = count if count > worst else worst
                done += 1
                alarm = None
            else:
                spare.append(r)
        # the flood keeps coming: refill the queue before the next frame
        while not q.is_full() and spare:
            r = spare.pop()
            r.req_id = rid & 0xFFFF
            r.priority = rng.range(10, 16)
            r.deadline = ticks_add(now, 3600000)
            rid += 1
            q.push(r, now)
        frame = q.pop(now)
        if alarm is not None:
            if frame is alarm:
                if count > worst:
                    worst = count
                done += 1
                alarm = None
                frame = TxRequest(0, 1, 16, 0)  # recycle a fresh object
            else:
                count += 1
    return worst


def run(emit, quick=False):
    # quick: 500 cycles on a queue of 50, 5 alarms in a flood of 200
    ops_size = (500, 50) if quick else (20000, 1000)
    flood = (5, 200) if quick else (100, 10000)
    gc.collect()
    ops = bench_queue_ops(*ops_size)
    emit("queue_ops_per_s", int(ops), "ops/s")
    gc.collect()
    emit("alarm_latency_frames_under_flood", bench_alarm_latency(*flood), "frames")
    gc.collect()
    # fairness aging (one class per second waited) and what it costs: alarms
    # keep their place; class-2 telemetry now competes with aged flood classes
    emit("alarm_latency_frames_under_flood_aging", bench_alarm_latency(*flood, aging_ms=1000), "frames")
    gc.collect()
    emit("telemetry_latency_frames_under_flood", bench_alarm_latency(*flood, prio=2), "frames")
    gc.collect()
    emit("telemetry_latency_frames_under_flood_aging", bench_alarm_latency(*flood, aging_ms=1000, prio=2), "frames")
    gc.collect()


if __name__ == "__main__":
    run(emit_json, quick_argv())
