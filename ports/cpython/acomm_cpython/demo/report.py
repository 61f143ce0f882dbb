# What the demo mission measured: a summary dict (printed as a table, or as
# JSON with --json), the per-packet CSV, and PNG plots when matplotlib is
# installed (`pip install .[plot]`; `make demo` does it).
import os

from acomm_sim.metrics import median

CLASS_ORDER = ("alarm", "teleop", "answer", "status", "auv_state", "position", "log")


def _s(ms):
    return None if ms is None else round(ms / 1000, 3)


def summary(m, wall_s):
    log = m.traffic.log
    rows = []
    for (cls, link), s in sorted(log.summaries(seed=m.seed).items(), key=lambda kv: (CLASS_ORDER.index(kv[0][0]), kv[0][1])):
        ci = s["latency_median_ci95_ms"]
        rows.append({
            "class": cls,
            "link": link,
            "sent": s["sent"],
            "received": s["received"],
            "pdr": None if s["pdr"] is None else round(s["pdr"], 4),
            "latency_mean_s": _s(s["latency_mean_ms"]),
            "latency_median_s": _s(s["latency_median_ms"]),
            "latency_median_ci95_s": None if ci is None else [_s(ci[0]), _s(ci[1])],
            "jitter_s": _s(s["jitter_ms"]),
        })
    sim_s = m.world.now() / 1000
    out = {
        "seed": m.seed,
        "simulated_s": sim_s,
        "wall_s": round(wall_s, 2),
        "speedup": round(sim_s / wall_s, 1) if wall_s > 0 else None,
        "traffic": rows,
        "discovery_s": _s(max(m.discovered.values())) if len(m.discovered) == 6 else None,
        "caddy": _caddy(m),
        "log": _log(m),
        "alarm": _alarm(m),
        "teleop": _teleop(m),
        "outage": _outage(m),
        # the buoy's Iridium path to the shore node (demo.uplink): DirectIP both ways
        "uplink": None if m.uplink is None else m.uplink.summary(),
        "channel": {k: getattr(m.channel, k) for k in ("sent", "collided", "deaf", "range_lost", "noise_lost")},
    }
    return out


def _caddy(m):
    c = m.caddy
    if c is None:
        return {"note": "not run"}
    t = sorted(c.cycle_times_ms)
    return {
        "cycles": c.cycles,
        "cycle_median_s": _s(median(t)) if t else None,
        "cycle_min_s": _s(t[0]) if t else None,
        "seed_budget_s": 7.24,
        "seed_budget_with_sonar_s": 7.64,
    }


def _log(m):
    d = m.log
    if d.queued_at is None:
        return None
    got, total, b, size = d.progress()
    return {"lines": total, "bytes": size, "received": got, "queued_s": _s(d.queued_at),
            "complete_s": _s(d.done_at), "duration_s": _s(None if d.done_at is None else d.done_at - d.queued_at)}


def _alarm(m):
    e = m.alarm
    if e is None:
        return None
    rows = m.traffic.log.rows
    lat = None if e[4] is None else e[4] - rows[e[0]][6]
    behind = [x for x in m.log.entries if x[4] is None or (e[4] is not None and x[4] > e[4])]
    return {"latency_s": _s(lat), "log_lines_delivered_after_it": len(behind),
            "answer_latency_s": None if m.answer is None or m.answer[4] is None else _s(m.answer[4] - rows[m.answer[0]][6])}


def _teleop(m):
    v = m.vehicle
    return {
        "commands": m.pilot.commands,
        "heartbeats": m.pilot.heartbeats,
        "failsafe_trips": [[_s(t), r] for t, r in v.trips],
        "failsafe_recoveries_s": [_s(t) for t in v.recoveries],
        "auv_travelled_m": round(v.travelled, 1),
    }


def _outage(m):
    # what was queued while nobody could hear: one-way messages went out
    # into the noise and are lost; acknowledged ones waited and flowed after
    if m.outage is None:
        return None
    start, end = m.outage
    rows = [r for r in m.traffic.log.rows.values() if start <= r[6] < end]
    after = [r for r in rows if r[7] is not None]
    lat = [r[7] - r[6] for r in after]
    return {"start_s": _s(start), "end_s": _s(end), "queued_during": len(rows),
            "received_during": len([r for r in after if r[7] < end]),
            "delivered_after": len([r for r in after if r[7] >= end]),
            "lost": len(rows) - len(after),
            "latency_max_s": _s(max(lat)) if lat else None,
            "last_arrived_s": _s(max(r[7] for r in after)) if after else None}


def table(s):
    lines = []
    lines.append("%-10s %-12s %5s %5s %6s %9s %9s %19s %8s" % ("class", "link", "sent", "recv", "PDR", "mean s",
                                                               "median s", "median 95% CI s", "jitter s"))
    for r in s["traffic"]:
        ci = r["latency_median_ci95_s"]
        lines.append("%-10s %-12s %5d %5d %6s %9s %9s %19s %8s" % (
            r["class"], r["link"], r["sent"], r["received"], _f(r["pdr"], "%.3f"), _f(r["latency_mean_s"]),
            _f(r["latency_median_s"]), "-" if ci is None else "[%.2f, %.2f]" % (ci[0], ci[1]), _f(r["jitter_s"])))
    return "\n".join(lines)


def _f(v, fmt="%.2f"):
    return "-" if v is None else fmt % v


def pyplot():
    """matplotlib.pyplot drawing to files (the Agg backend), or None when matplotlib is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt


def plots(m, outdir):
    # -> paths written, or [] when matplotlib is missing
    plt = pyplot()
    if plt is None:
        return []
    log = m.traffic.log
    rows = [log.rows[p] for p in log.order]
    classes = [c for c in CLASS_ORDER if any(r[1] == c for r in rows)]
    paths = []

    fig, ax = plt.subplots(figsize=(8, 4))
    data = [[(r[7] - r[6]) / 1000 for r in rows if r[1] == c and r[7] is not None] for c in classes]
    # (the keyword for box labels changed name in matplotlib 3.9: set ticks)
    ax.boxplot([d or [0] for d in data])
    ax.set_xticks(range(1, len(classes) + 1))
    ax.set_xticklabels(classes)
    ax.set_yscale("log")
    ax.set_ylabel("latency, s (queued to received)")
    ax.set_title("Latency per traffic class")
    paths.append(_save(fig, outdir, "latency.png"))

    fig, ax = plt.subplots(figsize=(8, 4))
    groups = log.summaries(resamples=10)
    keys = sorted(groups, key=lambda k: (CLASS_ORDER.index(k[0]), k[1]))
    ax.bar(range(len(keys)), [groups[k]["pdr"] for k in keys])
    ax.set_xticks(range(len(keys)))
    ax.set_xticklabels(["%s\n%s" % k for k in keys], fontsize=7)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("packet delivery ratio")
    ax.set_title("PDR per class and link")
    paths.append(_save(fig, outdir, "pdr.png"))

    fig, ax = plt.subplots(figsize=(10, 4))
    for i, c in enumerate(classes):
        ok = [r for r in rows if r[1] == c and r[7] is not None]
        lost = [r for r in rows if r[1] == c and r[7] is None]
        ax.scatter([r[6] / 60000 for r in ok], [i] * len(ok), s=8, c="tab:blue")
        ax.scatter([r[6] / 60000 for r in lost], [i] * len(lost), s=14, c="tab:red", marker="x")
    for start, end, label in m.spans:
        ax.axvspan(start / 60000, end / 60000, alpha=0.12, color="gray")
        ax.text(start / 60000 + 0.05, len(classes) - 0.55, label, fontsize=7)
    ax.set_ylim(-0.6, len(classes) - 0.3)  # room for the phase names on top
    ax.set_yticks(range(len(classes)))
    ax.set_yticklabels(classes)
    ax.set_xlabel("minutes (queued at; x = never received)")
    ax.set_title("Timeline")
    paths.append(_save(fig, outdir, "timeline.png"))
    plt.close("all")
    return paths


def _save(fig, outdir, name):
    p = os.path.join(outdir, name)
    fig.tight_layout()
    fig.savefig(p, dpi=100)
    return p
