# `acomm replay FILE --driver NAME`: the front end of acomm_cpython.emulate.replay,
# which feeds a capture's modem -> host bytes through a driver at their
# recorded times; prints the driver's events, one per line.
import sys

from ..emulate.capture import CaptureError, read_capture
from ..emulate.replay import describe, event_names, make_driver, replay


def add_arguments(p):
    p.add_argument("file", help="a capture (JSON lines), e.g. from acomm emulate ... --log FILE")
    p.add_argument("--driver", help="the driver to feed (default: the capture header's modem)")
    p.add_argument("--address", type=int, default=1, help="the driver's own address (default 1)")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", help="driver option (repeatable)")
    p.add_argument("--step-ms", type=int, default=10, help="poll the driver this often between records")
    p.add_argument("--tail-ms", type=int, default=0, help="run the driver on this long after the last record")
    p.add_argument("--writes", action="store_true", help="also print what the driver wrote ('> hex')")


def main(args):
    from ..modems import parse_options

    try:
        with open(args.file, encoding="utf-8", errors="replace") as f:
            header, records = read_capture(f)
    except OSError as e:
        print("%s: %s" % (args.file, e.strerror or e), file=sys.stderr)
        return 2
    except CaptureError as e:
        print("%s:%d: damaged capture: %s" % (args.file, e.line, e.reason), file=sys.stderr)
        return 2
    try:
        options = parse_options(args.option)
    except ValueError as e:
        print(e, file=sys.stderr)
        return 2
    name = args.driver or header.get("modem")
    try:
        driver = make_driver(name, args.address, options)
    except (ValueError, TypeError) as e:
        print("%s: cannot make the %s driver: %s" % (args.file, name, e), file=sys.stderr)
        return 2
    names = event_names()

    def writes(t, data):
        print("%d > %s" % (t, data.hex()))

    for t, ev in replay(records, driver, args.step_ms, args.tail_ms, writes if args.writes else None):
        print("%d %s" % (t, describe(ev, names)))
    return 0
