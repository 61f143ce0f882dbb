# Shared helpers for link tests: collect events, and check the rule that
# every accepted request ends with exactly one final status.
from acomm.events import EV_STATUS, FAILED, QUEUED, is_final


class Recorder:
    def __init__(self):
        self.events = []

    def __call__(self, ev):
        self.events.append(ev)

    def of(self, code):
        return [e for e in self.events if e[0] == code]

    def statuses(self, req_id):
        return [e[3] for e in self.events if e[0] == EV_STATUS and e[2] == req_id]

    def reasons(self, req_id):
        return [e[4] for e in self.events if e[0] == EV_STATUS and e[2] == req_id]

    def final(self, req_id):
        f = [s for s in self.statuses(req_id) if is_final(s)]
        return f[-1] if f else None


def check_exactly_one_final(rec, req_ids):
    # Every request id either was refused at once (a single FAILED and
    # nothing else) or was queued and then reached exactly one final status,
    # after which nothing more was said about it.
    for rid in req_ids:
        st = rec.statuses(rid)
        assert st, "request %d got no status" % rid
        finals = [i for i, s in enumerate(st) if is_final(s)]
        assert len(finals) == 1, "request %d: statuses %r" % (rid, st)
        assert finals[0] == len(st) - 1, "request %d: status after final %r" % (rid, st)
        if st[0] != QUEUED:
            assert st == [FAILED], "request %d: %r" % (rid, st)
