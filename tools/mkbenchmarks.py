# Regenerate BENCHMARKS.md: runs `acomm bench compare --json` (echoing its
# lines), describes this machine, and writes the file with
# acomm_cpython.bench.benchmarks_md. Install the peers first: pip install -e '.[bench]'.
#
#   .venv/bin/python tools/mkbenchmarks.py [--out BENCHMARKS.md]
#   .venv/bin/python tools/mkbenchmarks.py --render-only   # re-render the kept figures
#   .venv/bin/acomm bench footprint --json > fp.jsonl
#   .venv/bin/python tools/mkbenchmarks.py --render-only --footprint fp.jsonl
#       # the kept figures, with the footprint section from that run (the
#       # footprint bench alone takes about as long as the rest of compare)
import argparse
import os
import platform
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mp = "no micropython"
    from acomm_cpython.bench.runtime import find_micropython

    exe = find_micropython()
    if exe:
        code = "import sys; print('%d.%d.%d' % sys.implementation.version[:3])"
        out = subprocess.run([exe, "-c", code], capture_output=True, text=True)
        mp = "MicroPython %s (unix port)" % out.stdout.strip()
    return "%s, %d CPUs, %s; CPython %s; %s" % (cpu, os.cpu_count() or 0, platform.platform(),
                                                 platform.python_version(), mp)


def run_bench():
    exe = os.path.join(os.path.dirname(sys.executable), "acomm")
    proc = subprocess.Popen([exe, "bench", "compare", "--json"], stdout=subprocess.PIPE, text=True)
    lines = []
    for line in proc.stdout:
        sys.stdout.write(line)
        lines.append(line)
    if proc.wait() != 0:
        raise SystemExit("acomm bench compare failed")
    return lines


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ROOT, "BENCHMARKS.md"))
    ap.add_argument("--render-only", action="store_true", help="re-render the figures kept in --out")
    ap.add_argument("--footprint", metavar="FILE",
                    help="with --render-only: the footprint figures from this `acomm bench footprint --json` output")
    args = ap.parse_args()
    from acomm_cpython.bench import benchmarks_md as bm

    if args.render_only:
        with open(args.out) as f:
            records, where = bm.figures_of(f.read())
        if args.footprint:
            with open(args.footprint) as f:
                fresh = [("footprint_" + n, v, u) for n, v, u in bm.parse(f)]
            records = [r for r in records if not r[0].startswith("footprint_")] + fresh
    else:
        records, where = bm.parse(run_bench()), machine()
    with open(args.out, "w") as f:
        f.write(bm.render(records, where))
    print("wrote %s" % args.out, file=sys.stderr)


if __name__ == "__main__":
    main()
