# A small filesystem of a test's own, to fill up for real: a tmpfs mounted
# in a mount namespace of the one command that uses it (`unshare -m` as
# root, `unshare -rm` as a user where the kernel allows user namespaces),
# so nothing outside sees it and it goes away with the command. Where
# neither works (a container without the capability) way() is None and
# the tests take the fault-injecting files instead (tests/core/faultfs.py).
# ACOMM_TEST_NO_MOUNT=1 makes way() None, to run that fallback here.

import os
import subprocess
import tempfile

_WAY = []


def way():
    """The command prefix that can mount a tmpfs here (["unshare", "-m"] or ["unshare", "-rm"]), or None."""
    if os.environ.get("ACOMM_TEST_NO_MOUNT") == "1":
        return None
    if not _WAY:
        _WAY.append(None)
        d = tempfile.mkdtemp(prefix="acomm-smallfs-")
        try:
            for pre in (["unshare", "-m"], ["unshare", "-rm"]):
                try:
                    r = subprocess.run(in_tmpfs(pre, d, 64, ["true"]), stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL, timeout=30)
                except (OSError, subprocess.TimeoutExpired):
                    continue
                if r.returncode == 0:
                    _WAY[0] = pre
                    break
        finally:
            os.rmdir(d)
    return _WAY[0]


def in_tmpfs(pre, mnt, size_k, argv, ro=False, filler=0):
    """argv, run with a fresh tmpfs of size_k KiB at the empty folder mnt (read-only with ro) that only it sees.

    filler: bytes of a file mnt/filler written first, leaving that much
    less room; a test frees it through /proc/PID/root (filler_path)."""
    script = 'mount -t tmpfs -o size=%dk tmpfs "$0" || exit 97\n' % size_k
    if filler:
        script += 'head -c %d /dev/zero > "$0/filler" || exit 98\n' % filler
    if ro:
        script += 'mount -o remount,ro "$0" || exit 99\n'
    return pre + ["sh", "-c", script + 'exec "$@"', mnt] + list(argv)


def filler_path(pid, mnt):
    """The filler file of the tmpfs at mnt as the process pid sees it (its mount namespace)."""
    return "/proc/%d/root%s/filler" % (pid, mnt)
