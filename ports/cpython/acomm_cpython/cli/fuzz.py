# `acomm fuzz`: runs acomm_sim.fuzz (the portable engine and its targets)
# for a time or a number of cases, and prints one JSON line per target:
# inputs tried, failures, and for each of the first failures the case
# number and input to reproduce it:
#   acomm fuzz --seconds 60 [--seed S] [--target NAME ...]
#   acomm fuzz --seed S --target T --case N     (one case again)
#   acomm fuzz --corpus DIR ...   keep the inputs that reached new lines of
#                                 acomm and mutate them further, and add this
#                                 run to DIR's cumulative counts and coverage
#                                 (acomm_cpython.bench.fuzzcov)
# Exit status 1 when anything failed.
import json
import tempfile


def add_arguments(p):
    p.add_argument("--seconds", type=float, default=10.0, help="real time to run, shared by the targets")
    p.add_argument("--cases", type=int, default=None, help="run this many cases per target instead of a time")
    p.add_argument("--seed", type=int, default=None,
                   help="the inputs are a function of seed, target and case (and, with --corpus, of the inputs "
                        "kept); default 1, or with --corpus one more than the runs DIR has counted")
    p.add_argument("--target", action="append", help="only this target (repeatable); --list names them")
    p.add_argument("--case", type=int, default=None, help="run one case (needs --target)")
    p.add_argument("--list", action="store_true", help="list the targets and exit")
    p.add_argument("--corpus", metavar="DIR", help="keep inputs that reach new code, and cumulative counts, in DIR")
    p.add_argument("--trace-every", type=int, default=8, metavar="K",
                   help="with --corpus: trace one case in K for coverage (default 8)")


def _bad_args(args):
    # -> what is wrong with the arguments, or None
    if args.seconds <= 0:
        return "--seconds must be positive, not %g" % args.seconds
    if args.cases is not None and args.cases <= 0:
        return "--cases must be positive, not %d" % args.cases
    if args.case is not None and (args.case < 0 or not args.target):
        return "--case needs a number >= 0 and --target"
    if args.trace_every < 1:
        return "--trace-every must be 1 or more"
    return None


def main(args):
    import sys

    from acomm_sim import fuzz

    bad = _bad_args(args)
    if bad:
        print("acomm fuzz: " + bad, file=sys.stderr)
        return 2

    with tempfile.TemporaryDirectory(prefix="acomm-fuzz-") as tmp:
        targets = fuzz.all_targets(args.target, tmp)
        if args.list:
            for t in targets:
                print(t.name)
            return 0
        if not targets:
            print("acomm fuzz: no such target: %s (--list names them)" % ", ".join(args.target), file=sys.stderr)
            return 2
        if args.seed is None and (args.case is not None or not args.corpus):
            args.seed = 1
        if args.case is not None:
            bad = 0
            for t in targets:
                r = fuzz.run_case(t, args.seed, args.case)
                print(json.dumps({"target": t.name, "case": args.case, "failed": r is not None,
                                  "error": r[1] if r else None, "input": r[0].hex() if r else None}))
                bad += r is not None
            return 1 if bad else 0
        ms = None if args.cases is not None else int(args.seconds * 1000)
        tracer = None
        if args.corpus:
            from ..bench.fuzzcov import Tracer

            tracer = Tracer(args.corpus, args.trace_every)
            tracer.load_corpus(targets)
            if args.seed is None:
                args.seed = tracer.runs() + 1  # every run its own inputs
        import time

        t0 = time.monotonic()
        results = fuzz.run(targets, seed=args.seed, ms=ms, cases=args.cases, hook=tracer)
        seconds = time.monotonic() - t0
    total = fails = 0
    for r in results:
        total += r.inputs
        fails += r.failures
        print(json.dumps({"target": r.name, "inputs": r.inputs, "failures": r.failures, "seconds": round(r.ms / 1000, 1),
                          "first": [{"case": c, "error": e, "input": d.hex()} for c, d, e in r.first]}))
    print(json.dumps({"target": "total", "seed": args.seed, "inputs": total, "failures": fails}))
    if tracer is not None:
        tot = tracer.save(results, seconds)
        hit, of = tracer.coverage()
        print(json.dumps({"target": "cumulative", "runs": tot["runs"], "seconds": tot["seconds"],
                          "inputs": sum(tot["inputs"].values()), "failures": sum(tot["failures"].values()),
                          "kept_this_run": sum(tracer.kept.values())}))
        print(json.dumps({"target": "coverage", "acomm_function_lines": of, "reached": hit,
                          "percent": round(100.0 * hit / of, 1) if of else 0.0}))
    return 1 if fails else 0
