# Small assertion helpers shared by the core tests (no pytest on MicroPython).


def raises(exc, fn, *args):
    # Calls fn(*args); asserts it raised an instance of exc; returns it.
    try:
        fn(*args)
    except Exception as e:  # noqa: BLE001 - the point is to see everything
        assert isinstance(e, exc), repr(e)
        return e
    assert False, "no %s from %r" % (exc.__name__, args)


# The epsilon of this runtime's float: IEEE double on CPython and the unix
# ports, single on boards built with float32 (RP2040, ESP32, the Cortex-M3
# test firmware), where 1 + 2**-40 rounds to 1.
EPS = 2.0**-52 if 1.0 + 2.0**-40 != 1.0 else 2.0**-23
DOUBLE = EPS < 1e-10


def near(scale=1.0):
    # How far float arithmetic on values of about `scale` may stray from the
    # exact result here: 1e-9 with doubles, a few ulps of float32 on a board.
    return max(1e-9, 4 * abs(scale) * EPS)


try:
    from pytest import skip  # noqa: F401 - under pytest, its own skip
except ImportError:

    class Skip(Exception):
        # A test that cannot run on this runtime, and why: the MicroPython
        # runners count it apart, neither passed nor failed.
        pass

    def skip(reason):
        # Ends the calling test as skipped.
        raise Skip(reason)


def need_double(what):
    # Skips the calling test on a float32 runtime: `what` needs IEEE double.
    if not DOUBLE:
        skip("%s: needs double-precision floats, and this runtime has float32" % what)


def tmp_root():
    # /tmp, made when the filesystem has none (a board's littlefs at "/",
    # as on the Cortex-M3 firmware of tools/board_runtests.py)
    import os

    try:
        os.mkdir("/tmp")
    except OSError:
        pass
    return "/tmp"


class TempDir:
    # A fresh folder under /tmp, removed with what it holds on leaving.
    def __enter__(self):
        import os

        from acomm.compat import ticks_ms

        # os.urandom where the port has it (the qemu Cortex-M3 port has
        # not): the clock and a try count otherwise, until mkdir succeeds
        n = 0
        while True:
            try:
                tag = "%012x" % int.from_bytes(os.urandom(6), "big")
            except AttributeError:
                tag = "%d-%d" % (ticks_ms(), n)
            self.path = tmp_root() + "/acomm-test-" + tag
            try:
                os.mkdir(self.path)
                return self
            except OSError:
                n += 1
                if n > 100:
                    raise

    def __exit__(self, *exc):
        import os

        for n in os.listdir(self.path):
            os.remove(self.path + "/" + n)
        os.rmdir(self.path)

    def file(self, name="s"):
        return self.path + "/" + name


def adjacency(edges):
    """{node: set of neighbours} of an undirected graph given as (a, b) edges."""
    adj = {}
    for a, b in edges:
        adj.setdefault(a, set()).add(b)
        adj.setdefault(b, set()).add(a)
    return adj
