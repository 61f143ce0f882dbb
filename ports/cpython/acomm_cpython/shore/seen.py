# The (IMEI, MOMSN) pairs a shore has taken: a replayed RockBLOCK POST is
# refused by it, and a DirectIP message sent again (its confirmation was
# lost on the way) is confirmed again without a second delivery.


class Replays:
    """The (imei, momsn) pairs taken, at most capacity; when full the oldest is forgotten
    (a POST older than max_age_s is refused as stale anyway, so capacity must exceed what
    max_age_s can bring)."""

    def __init__(self, capacity=4096):
        self.capacity = capacity
        self._seen = {}  # insertion order: oldest first

    def seen(self, key):
        return key in self._seen

    def add(self, key):
        self._seen[key] = True
        if len(self._seen) > self.capacity:
            del self._seen[next(iter(self._seen))]
