# Small assertion helpers shared by the core tests (no pytest on MicroPython).


def raises(exc, fn, *args):
    # Calls fn(*args); asserts it raised an instance of exc; returns it.
    try:
        fn(*args)
    except Exception as e:  # noqa: BLE001 - the point is to see everything
        assert isinstance(e, exc), repr(e)
        return e
    assert False, "no %s from %r" % (exc.__name__, args)
