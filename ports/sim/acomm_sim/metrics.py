# What a simulation run measured, packet by packet: delivery ratio,
# end-to-end latency (mean, median, bootstrap 95 % confidence intervals) and
# jitter as seed 004 defines it, J = mean |L_k - L_(k-1)| over the packets
# received, in the order they were sent. Rows are kept so that the run can be
# written as CSV (one row per packet) for any other tool to read.
# Portable Python; the bootstrap draws from acomm.prng so results repeat.

from acomm.prng import Prng

CSV_HEADER = "id,class,link,src,dst,size,t_sent_ms,t_received_ms,latency_ms"


def median(xs):
    s = sorted(xs)
    n = len(s)
    if not n:
        return None
    m = n // 2
    return s[m] if n % 2 else (s[m - 1] + s[m]) / 2


def mean(xs):
    return sum(xs) / len(xs) if xs else None


def latency_steps(latencies):
    # |L_k - L_(k-1)| for consecutive received packets
    return [abs(latencies[i] - latencies[i - 1]) for i in range(1, len(latencies))]


def jitter(latencies):
    # seed 004: mean absolute difference of consecutive latencies (its
    # Table II also gives the median of the same differences)
    return mean(latency_steps(latencies))


def bootstrap_ci(xs, stat, resamples=1000, seed=1, level=0.95):
    # percentile bootstrap: (low, high) of `stat` over resamples of xs
    n = len(xs)
    if n < 2:
        return None
    rng = Prng(seed)
    vals = []
    for _ in range(resamples):
        vals.append(stat([xs[rng.below(n)] for _ in range(n)]))
    vals.sort()
    lo = int((1 - level) / 2 * resamples)
    hi = min(resamples - 1, int((1 + level) / 2 * resamples))
    return vals[lo], vals[hi]


class PacketLog:
    def __init__(self, capacity=100000):
        self.capacity = capacity
        self.rows = {}  # id -> [id, cls, link, src, dst, size, sent, received]
        self.order = []
        self.dropped = 0  # rows not kept because the log was full
        self.duplicates = 0
        self.unknown = 0

    def sent(self, pid, cls, link, src, dst, size, t):
        if pid in self.rows:
            return
        if len(self.order) >= self.capacity:
            self.dropped += 1
            return
        self.rows[pid] = [pid, cls, link, src, dst, size, t, None]
        self.order.append(pid)

    def received(self, pid, t):
        r = self.rows.get(pid)
        if r is None:
            self.unknown += 1
        elif r[7] is not None:
            self.duplicates += 1
        else:
            r[7] = t

    def latency(self, r):
        return None if r[7] is None else r[7] - r[6]

    def groups(self, key=lambda r: (r[1], r[2])):
        g = {}
        for pid in self.order:
            r = self.rows[pid]
            g.setdefault(key(r), []).append(r)
        return g

    def summary(self, rows=None, resamples=1000, seed=1):
        if rows is None:
            rows = [self.rows[p] for p in self.order]
        lat = [self.latency(r) for r in rows if r[7] is not None]
        s = {
            "sent": len(rows),
            "received": len(lat),
            "pdr": len(lat) / len(rows) if rows else None,
            "latency_mean_ms": mean(lat),
            "latency_median_ms": median(lat),
            "latency_mean_ci95_ms": bootstrap_ci(lat, mean, resamples, seed),
            "latency_median_ci95_ms": bootstrap_ci(lat, median, resamples, seed),
            "jitter_ms": jitter(lat),
        }
        return s

    def summaries(self, resamples=1000, seed=1):
        # {(class, link): summary}
        return {k: self.summary(v, resamples, seed) for k, v in self.groups().items()}

    def csv_lines(self):
        yield CSV_HEADER
        for pid in self.order:
            r = self.rows[pid]
            lat = self.latency(r)
            yield "%s,%s,%s,%s,%s,%d,%d,%s,%s" % (
                r[0], r[1], r[2], r[3], r[4], r[5], r[6],
                "" if r[7] is None else "%d" % r[7],
                "" if lat is None else "%d" % lat,
            )

    def write_csv(self, path):
        with open(path, "w") as f:
            for line in self.csv_lines():
                f.write(line)
                f.write("\n")
