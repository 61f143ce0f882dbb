# Small assertion helpers shared by the core tests (no pytest on MicroPython).


def raises(exc, fn, *args):
    # Calls fn(*args); asserts it raised an instance of exc; returns it.
    try:
        fn(*args)
    except Exception as e:  # noqa: BLE001 - the point is to see everything
        assert isinstance(e, exc), repr(e)
        return e
    assert False, "no %s from %r" % (exc.__name__, args)


class TempDir:
    # A fresh folder under /tmp, removed with what it holds on leaving.
    def __enter__(self):
        import os
        from binascii import hexlify

        self.path = "/tmp/acomm-test-" + hexlify(os.urandom(6)).decode()
        os.mkdir(self.path)
        return self

    def __exit__(self, *exc):
        import os

        for n in os.listdir(self.path):
            os.remove(self.path + "/" + n)
        os.rmdir(self.path)

    def file(self, name="s"):
        return self.path + "/" + name
