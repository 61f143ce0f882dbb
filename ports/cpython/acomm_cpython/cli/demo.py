# `acomm demo` (and `make demo`): the main job on a machine without modems.
# Runs the mission of acomm_cpython.demo.mission on the simulated ocean, prints its
# timeline as it goes and a summary at the end, and writes the per-packet CSV
# and (with matplotlib) PNG plots to --out. `--json` prints only the summary.
# `--web [HOST:]PORT` serves the buoy's operator console while the mission
# runs, paced at --speed times real time (demo/web.py).
import json
import os
import time

from ..demo import report
from ..demo.mission import Mission


def add_arguments(p):
    p.add_argument("--mission", choices=("caddy", "relay"), default="caddy",
                   help="caddy: the diver, the buoy and the AUV at work (default); relay: the diver swims out of "
                        "the buoy's range and reports through the AUV, on routes the nodes find (docs/routing.md)")
    p.add_argument("--seed", type=int, default=1, help="the run is the same for the same seed")
    p.add_argument("--minutes", type=float, default=20, help="simulated minutes (the plan fills 20)")
    p.add_argument("--out", default="demo-out", help="folder for packets.csv and the plots")
    p.add_argument("--json", action="store_true", help="print the summary as JSON only")
    p.add_argument("--no-plots", action="store_true", help="do not draw PNG plots")
    p.add_argument("--web", metavar="[HOST:]PORT", help="serve the buoy's operator console here while the mission "
                   "runs paced (loopback unless a HOST is given; docs/console.md)")
    p.add_argument("--speed", type=float, metavar="X", help="with --web: X times real time (default 10)")
    p.add_argument("--web-password-file", metavar="PATH", help="with --web: the console's password, in a file")
    p.add_argument("--linger", action="store_true", help="with --web: keep serving after the mission, until Ctrl-C")
    p.add_argument("--site", metavar="FILE", help="a scenario file (JSON; TOML on Python 3.11+): the water, weather and "
                   "modem models of a physics channel instead of the loss curve (docs/simulator.md)")


def main(args):
    scenario = None
    if getattr(args, "site", None):
        from acomm_sim.site import load

        try:
            scenario = load(args.site)
        except (OSError, ValueError, KeyError) as e:
            print("acomm demo: --site %s: %s" % (args.site, e))
            return 2
    if args.minutes <= 0:
        print("acomm demo: --minutes must be positive")
        return 2
    if args.web is None and (args.speed is not None or args.web_password_file or args.linger):
        print("acomm demo: --speed, --web-password-file and --linger go with --web")
        return 2
    if args.speed is not None and args.speed <= 0:
        print("acomm demo: --speed must be positive")
        return 2
    say = None if args.json else print
    if args.mission == "relay":
        if args.web is not None or scenario is not None:
            print("acomm demo: --web and --site go with the caddy mission")
            return 2
        from ..demo import relay

        if say:
            print("acomm demo: relay mission: the diver reports to the buoy through the AUV, on routes nobody typed")
            print("            real acomm nodes and SeaTrac drivers against emulated beacons; seed %d, %g minutes"
                  % (args.seed, args.minutes))
            print()
        return relay.main(args, say)
    if args.web is not None and say is not None:
        say = _flushed  # a browser test reads the timeline through a pipe
    if say:
        print("acomm demo: a buoy, a diver and a companion AUV on a simulated acoustic channel")
        print("            real acomm nodes and SeaTrac drivers against emulated beacons; seed %d, %g minutes"
              % (args.seed, args.minutes))
        print()
    t0 = time.perf_counter()
    if args.web is None:
        m = Mission(seed=args.seed, minutes=args.minutes, say=say, scenario=scenario).run()
        web = None
    else:
        from acomm.errors import AcommError

        from ..demo.web import USBL_NOISE, WebDemo

        m = Mission(seed=args.seed, minutes=args.minutes, say=say, usbl_noise=USBL_NOISE, scenario=scenario)
        try:
            web = WebDemo(args, m)
        except ImportError as e:
            print("acomm demo: --web needs microdot: pip install 'acomm[web]' (%s)" % e)
            return 2
        except (ValueError, AcommError) as e:
            print("acomm demo: --web: %s" % e)
            return 2
        try:
            if not web.run():
                web.close()
                return 0
        except OSError as e:
            print("acomm demo: --web %s: %s" % (args.web, e))
            return 1
    wall = time.perf_counter() - t0
    try:
        return _report(args, m, wall, web)
    finally:
        if web is not None:
            web.close()


def _flushed(text):
    print(text, flush=True)


def _report(args, m, wall, web):
    s = report.summary(m, wall)
    os.makedirs(args.out, exist_ok=True)
    csv = os.path.join(args.out, "packets.csv")
    m.traffic.log.write_csv(csv)
    s["csv"] = csv
    s["plots"] = [] if args.no_plots else report.plots(m, args.out)
    if args.json:
        print(json.dumps(s))
        return 0
    print()
    print("summary: %.0f simulated s in %.1f s of wall time (%.0fx)" % (s["simulated_s"], s["wall_s"], s["speedup"] or 0))
    print()
    print(report.table(s))
    print()
    for key in ("caddy", "log", "alarm", "teleop", "outage", "uplink", "channel"):
        if s[key] is not None:
            print("%-8s %s" % (key, json.dumps(s[key])))
    if s["discovery_s"] is not None:
        print("%-8s every node knew every other after %.1f s" % ("discover", s["discovery_s"]))
    print()
    print("per-packet log: %s" % csv)
    if s["plots"]:
        print("plots: %s" % ", ".join(s["plots"]))
    elif not args.no_plots:
        print("plots: none (pip install '.[plot]' for matplotlib)")
    if web is not None and args.linger:
        web.linger()
    return 0
