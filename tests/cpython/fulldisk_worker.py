# The store on a disk that fills up, run by tests/cpython/test_store_full_disk.py:
# inside a tmpfs of its own (smallfs: a real ENOSPC, the filesystem's own
# partial writes) or, where nothing can be mounted, on fault-injecting
# files (tests/core/faultfs.py). Prints one JSON line of what it saw.
#
#   python fulldisk_worker.py DIR real|fault
#
# real: DIR is the small tmpfs with DIR/filler taking most of it; freeing
# it is "room again". fault: DIR is any folder; the fault layer's budget.

import json
import os
import sys

from acomm.errors import StoreFull
from acomm.transport.store import Store

HERE = os.path.dirname(os.path.abspath(__file__))


def data(k):
    return bytes((k * 37 + i) & 0xFF for i in range(300 + k % 200))


def main(d, how):
    opener = fs = None
    if how == "fault":
        sys.path.insert(0, os.path.join(os.path.dirname(HERE), "core"))
        from faultfs import FaultFS

        fs = FaultFS(free=24 * 1024)
        opener = fs.open
    path = os.path.join(d, "store")
    s = Store(path, capacity_bytes=1 << 20, max_record=1024, opener=opener)
    acked = []
    why = None
    for k in range(1000):
        try:
            s.put(k, data(k))
        except StoreFull as e:
            why = str(e)
            break
        acked.append(k)
    out = {"how": how, "acked": len(acked), "why": why}
    # full: the same record is refused again (the refused one's partial
    # write was cut off, no more), and what it holds still reads back
    try:
        s.put(k, data(k))
        out["second"] = "taken"
    except StoreFull as e:
        out["second"] = str(e)
    out["reads"] = s.keys() == acked and all(s.get(k) == data(k) for k in acked)
    s.delete(acked[0])  # a tombstone or, without room for one, deferred: never raised
    out["deferred"] = s.stats["delete_deferred"]
    del acked[0]
    s.close()
    s = Store(path, capacity_bytes=1 << 20, max_record=1024, opener=opener)
    # a deferred delete comes back after a reopen (documented)
    back = [0] if out["deferred"] else []
    out["reopened"] = s.keys() == back + acked and all(s.get(k) == data(k) for k in acked)
    for k in back:
        acked.insert(0, k)
    # room again
    if how == "real":
        os.remove(os.path.join(d, "filler"))
    else:
        fs.free = None
    s.put(9999, data(9999))
    s.close()
    s = Store(path, capacity_bytes=1 << 20, max_record=1024)
    out["after"] = s.keys() == acked + [9999] and s.get(9999) == data(9999)
    out["torn"] = s.stats["torn_dropped"]
    s.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
