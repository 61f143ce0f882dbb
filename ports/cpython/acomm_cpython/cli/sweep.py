# `acomm sweep`: the front end of acomm_cpython.demo.sweep, a grid of
# simulated runs of a scenario over seeds, in this process, on local
# processes or on a Dask cluster; writes sweep.csv and the plots.
import os
import sys

from ..demo import sweep_scenarios as sc
from ..demo.sweep import parse_grid, sweep


def add_arguments(p):
    p.add_argument("--scenario", default="demo", choices=sorted(sc.SCENARIOS),
                   help="the network to run (demo: acomm demo's mission; grid: nodes on a square grid)")
    p.add_argument("--grid", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="a swept parameter and its values (repeat for more); parameters: demo: %s; grid: %s"
                   % (", ".join(sc.SCENARIOS["demo"]), ", ".join(sc.SCENARIOS["grid"])))
    p.add_argument("--seeds", type=int, default=10, help="seeds 1..N at every grid point")
    p.add_argument("--minutes", type=float, default=20, help="simulated minutes per run")
    p.add_argument("--out", default="sweep-out", help="folder for sweep.csv and the plots")
    p.add_argument("--workers", type=int, default=0, help="local processes (default: all cores; 1: this process)")
    p.add_argument("--scheduler", default=None,
                   help="a Dask scheduler's address (tcp://HOST:8786), or 'local' for a Dask LocalCluster")
    p.add_argument("--resume", action="store_true", help="skip the runs already in the CSV")
    p.add_argument("--no-plots", action="store_true", help="do not draw the plots")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--site", metavar="FILE", help="a scenario file (JSON; TOML on Python 3.11+): demo and grid run on "
                   "its physics channel, and --grid may sweep %s" % ", ".join(sc.SITE_PARAMS))


def main(args):
    site = None
    try:
        if args.site:
            if args.scenario not in ("demo", "grid"):
                raise ValueError("--site goes with the demo and grid scenarios")
            site = _site(args.site)
        grid = parse_grid(args.scenario, args.grid, site is not None)
    except (OSError, ValueError) as e:
        print("acomm sweep: %s" % e, file=sys.stderr)
        return 2
    if args.seeds < 1 or args.minutes <= 0:
        print("acomm sweep: --seeds and --minutes must be positive", file=sys.stderr)
        return 2
    try:
        rows, paths = sweep(args.scenario, grid, args.seeds, args.minutes, args.out, args.workers, args.scheduler,
                            args.resume, not args.no_plots, args.quiet, site)
    except (RuntimeError, ValueError) as e:
        print("acomm sweep: %s" % e, file=sys.stderr)
        return 1
    crashed = [r for r in rows if r["status"] != "ok"]
    print("%d runs in %s" % (len(rows), os.path.join(args.out, "sweep.csv")))
    for r in crashed:
        print("crashed: seed %s %s" % (r["seed"], {n: r[n] for n, _ in grid}))
    if paths:
        print("plots: %s" % ", ".join(paths))
    elif not args.no_plots:
        print("plots: none (pip install '.[plot]' for matplotlib; a sweep needs a swept parameter)")
    return 0


def _site(path):
    # the scenario file's content, checked (acomm_sim.site), as the runs take it
    from acomm_sim.site import parse, read

    data = read(path)
    parse(data)
    return data
