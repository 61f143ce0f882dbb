# The plots of `acomm sweep` (matplotlib, the `plot` extra): one PNG per
# swept parameter, PDR and median latency against its values, each point
# the mean over the seeds with a percentile-bootstrap 95 % interval
# (acomm_sim.metrics.bootstrap_ci, seeded, so the plot repeats), one line
# per combination of the other swept parameters. Crashed runs are left out.
import os

from acomm_sim.metrics import bootstrap_ci, mean

from .report import pyplot

PANELS = (("pdr", "PDR"), ("latency_p50_s", "median latency (s)"))


def _num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def series(rows, grid, param, measure):
    """{other params' values: [(value of param, mean, ci low, ci high, runs)]} over ok rows."""
    others = [n for n, _ in grid if n != param]
    values = dict(grid)[param]
    out = {}
    for r in rows:
        if r.get("status") != "ok":
            continue
        y = _num(r.get(measure))
        if y is None:
            continue
        key = tuple(str(r[n]) for n in others)
        out.setdefault(key, {}).setdefault(str(r[param]), []).append(y)
    res = {}
    for key, by_value in out.items():
        pts = []
        for v in values:
            ys = by_value.get(_fmt(v))
            if not ys:
                continue
            ci = bootstrap_ci(ys, mean, 1000, 1)
            m = mean(ys)
            pts.append((v, m, m if ci is None else ci[0], m if ci is None else ci[1], len(ys)))
        res[key] = pts
    return res


def _fmt(v):
    return repr(round(v, 6)) if isinstance(v, float) else str(v)


def plot_all(rows, grid, out):
    """-> paths of the PNGs written ([] without matplotlib or a swept parameter)."""
    if not grid:
        return []
    plt = pyplot()
    if plt is None:
        return []
    paths = []
    for param, values in grid:
        others = [n for n, _ in grid if n != param]
        numeric = all(isinstance(v, (int, float)) for v in values)
        fig, axes = plt.subplots(1, len(PANELS), figsize=(5 * len(PANELS), 3.8))
        for ax, (measure, label) in zip(axes, PANELS):
            for key, pts in sorted(series(rows, grid, param, measure).items()):
                if not pts:
                    continue
                xs = [p[0] if numeric else values.index(p[0]) for p in pts]
                ys = [p[1] for p in pts]
                err = [[p[1] - p[2] for p in pts], [p[3] - p[1] for p in pts]]
                name = ", ".join("%s=%s" % (n, k) for n, k in zip(others, key)) or "all"
                ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=name)
            if not numeric:
                ax.set_xticks(range(len(values)))
                ax.set_xticklabels([str(v) for v in values])
            ax.set_xlabel(param)
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        if axes[0].get_legend_handles_labels()[0]:
            axes[0].legend(fontsize="small")
        fig.suptitle("mean over seeds, bootstrap 95 % interval")
        fig.tight_layout()
        path = os.path.join(out, "sweep_%s.png" % param)
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths
