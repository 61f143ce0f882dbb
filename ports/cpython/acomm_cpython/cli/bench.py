# `acomm bench NAME [--json]`: the front end of the benchmarks' table
# (acomm_cpython.bench.table), which runs each workload on CPython and, for the
# figures that depend on the runtime, under the MicroPython unix port.
import json
import sys

from ..bench import table as bench


def add_arguments(b):
    b.add_argument("name", help="core, queue, discovery, ..., compare, or all (all but compare)")
    b.add_argument("--json", action="store_true", help="one JSON object per line")
    b.add_argument("--only", help="footprint: one group of figures (frozen_cortex_m, romfs_cortex_m, "
                                  "romfs_names_cortex_m, mpy_cortex_m, frozen_i386, romfs_i386, mpy_i386, "
                                  "flash_text, unix64, ...: footprint_workload.GROUPS)")
    b.add_argument("--open", action="store_true", help="attack: the nodes' key in open mode, to see what it allows")
    b.add_argument("--quick", action="store_true", help="each workload's code path with small sizes and short "
                                                         "timings, to check that it runs (the figures mean nothing)")


def main(args):
    names = [n for n in bench.BENCHES if n not in bench.NOT_IN_ALL] if args.name == "all" else [args.name]
    for n in names:
        if n not in bench.BENCHES:
            print("unknown benchmark %r; choose from: all, %s" % (n, ", ".join(bench.BENCHES)), file=sys.stderr)
            return 2

    def emit(name, value, unit):
        if args.json:
            print(json.dumps({"name": name, "value": round(value, 4) if isinstance(value, float) else value, "unit": unit}), flush=True)
        else:
            print("%-45s %12.4g %s" % (name, value, unit), flush=True)

    only = getattr(args, "only", None)
    if only and names != ["footprint"]:
        print("--only is for the footprint bench", file=sys.stderr)
        return 2
    if "footprint" in names:
        from ..board.boardfiles import in_checkout

        if not in_checkout() and args.name == "all":
            print("note: footprint skipped: it needs the firmware built in an acomm source checkout", file=sys.stderr)
            names.remove("footprint")
        elif not in_checkout():
            # its figures come from firmware built from MicroPython's source
            # with acomm frozen in (tools/firmware.py), which a wheel has not
            print("acomm bench footprint: needs the firmware built in an acomm source checkout (make firmware "
                  "there); an installed acomm has no firmware to measure", file=sys.stderr)
            return 1
    open_mode = getattr(args, "open", False)
    if open_mode and names != ["attack"]:
        print("--open is for the attack bench", file=sys.stderr)
        return 2
    try:
        bench.run(names, emit, only, open_mode, args.quick)
    except RuntimeError as e:  # a runtime the bench needs is missing: the message says which
        print("acomm bench %s: %s" % (args.name, e), file=sys.stderr)
        return 1
    return 0
