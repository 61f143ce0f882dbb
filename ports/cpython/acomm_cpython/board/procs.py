# The emulators' child processes (qemu, node, socat): tied to the life of
# the Python process that starts them.
import signal


def die_with_parent():
    """preexec_fn for subprocess.Popen: the child is killed when its parent dies, even by SIGKILL
    (a test runner's timeout), so an orphaned board never holds a core. Linux (prctl); elsewhere
    nothing."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
