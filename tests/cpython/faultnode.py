# `acomm node` with its --store on fault-injecting files (tests/core/faultfs.py),
# for tests/cpython/test_store_full_disk.py where no small filesystem can be
# mounted: the node's own code and files, with the disk's answers faked.
#
#   python faultnode.py FLAG node ARGS...
#
# While the file FLAG exists the store's disk is full (every write fails
# with ENOSPC); FLAG ending in ".ro": the disk is read-only (every open for
# writing fails with EROFS), as a read-only mount answers.

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "core"))

from faultfs import EROFS, FaultFS  # noqa: E402


class FlagFS(FaultFS):
    # full while the flag file exists
    def __init__(self, flag):
        FaultFS.__init__(self)
        self.flag = flag
        if flag.endswith(".ro"):
            self.refuse = EROFS

    @property
    def free(self):
        return 0 if os.path.exists(self.flag) else None

    @free.setter
    def free(self, v):
        pass  # the flag file decides


def main(argv):
    import acomm_cpython.cli.node as node_cli
    from acomm.transport.store import Store
    from acomm_cpython.cli import main as cli_main

    fs = FlagFS(argv[0])

    def open_store(path_dir, capacity=1 << 22, max_record=1024):
        # acomm_cpython.modems.open_store, with the faulty files
        os.makedirs(path_dir, exist_ok=True)
        return Store(os.path.join(path_dir, "acomm.store"), capacity_bytes=capacity, max_record=max_record,
                     opener=fs.open)

    node_cli.open_store = open_store
    return cli_main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
