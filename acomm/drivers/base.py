# What every sans-IO protocol machine (drivers, and the emulators in
# ports/sim) shares: an event list and an output buffer that the owner drains.


class SansIO:
    def __init__(self):
        self._events = []
        self._out = bytearray()

    def take_events(self):
        # Events since the last call (an empty list when there are none).
        ev = self._events
        if not ev:
            return ev
        self._events = []
        return ev

    def take_output(self):
        # Bytes to write to the device (b"" when there are none).
        if not self._out:
            return b""
        out = bytes(self._out)
        self._out = bytearray()
        return out
