# The footprint benchmark's lockstep run (acomm bench footprint): the buoy's
# node alone in the MicroPython unix port, from the .mpy files `acomm flash`
# stages, stepped with a simulated ocean in this process. A roomy heap
# completes the minute with frames both ways and the diver's packet in the
# buoy's custody; a heap far too small is reported as a failure, not hidden.
import shutil
import tempfile

from acomm_cpython.workloads import footprint_workload as fw


def test_the_lockstep_minute_runs_and_a_tiny_heap_fails():
    tmp = tempfile.mkdtemp(prefix="acomm-fp-test-")
    try:
        fl = fw._stage(tmp)
        r = fw.run_once(fl, 256 * 1024)
        assert r is not None and r["relayed"] == 1 and r["tx_frames"] > 0 and r["rx_frames"] > 0
        assert r["after_build"] < r["peak"] < 2 * 256 * 1024
        assert fw.run_once(fl, 16 * 1024) is None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
