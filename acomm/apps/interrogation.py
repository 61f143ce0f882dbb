# A scripted interrogation schedule (seed 003 section 6): a fixed list of
# steps, each one node interrogating another (a request the responder's
# modem answers by itself), repeated in a cycle. Every node runs its own
# copy of the schedule and keeps its own view of which step is under way;
# there is no master clock, only what each node observes:
#
#   interrogator  its request ended (delivered or failed)        -> next step
#   responder     the request reached it (its modem answers)      -> next step
#   listener      it overheard the reply (responder -> asker)     -> next step
#                 or the request (asker -> responder): the step started now
#   anyone        the step's timeout passed since the step began  -> next step
#
# so a lost packet costs one timeout and never stalls the cycle, and a node
# that missed a step catches up on the next frame it hears. Frames are
# matched to steps by (source, destination), looking ahead from the current
# step; a pair that appears twice (A->B as one step's request and another's
# reply) resolves to the nearer step.
#
#   s = Interrogation("buoy", [("buoy", "diver"), ("auv", "buoy", 5000)], 4000)
#   s.start(now)
#   dst = s.turn(now)          # a name when it is our turn to ask (once)
#   s.done(now, ok)            # our request's final status
#   s.heard(now, src, dst)     # every frame heard, ours and overheard
#   wake = s.poll(now)         # timeouts; when to poll again at the latest
#
# Portable Python (MicroPython and CPython); time is integer ms.

from ..compat import ticks_add, ticks_diff
from ..errors import AcommError


class Interrogation:
    def __init__(self, me, steps, timeout_ms=4000):
        if not steps:
            raise AcommError("an interrogation schedule needs at least one step")
        self.me = me
        self.steps = []
        for s in steps:
            if s[0] == s[1]:
                raise AcommError("%r cannot interrogate itself" % (s[0],))
            self.steps.append((s[0], s[1], s[2] if len(s) > 2 else timeout_ms))
        self.step = 0
        self.since = None  # when the current step began in our view; None: stopped
        self.asked = None  # the step we interrogated in, until it ends
        self._turned = False
        self.cycles = 0  # times our view went round the whole list
        self.timeouts = [0] * len(self.steps)  # steps we left on their timeout

    def start(self, now, step=0):
        self.since = now
        self.step = step % len(self.steps)
        self.asked = None
        self._turned = False

    def stop(self):
        self.since = None

    def running(self):
        return self.since is not None

    def _go(self, j, now):
        n = len(self.steps)
        if j >= n:
            self.cycles += 1
        self.step = j % n
        self.since = now
        self.asked = None
        self._turned = False

    def turn(self, now):
        # The responder's name when the current step is ours to ask and we
        # have not asked yet; None otherwise.
        if self.since is None or self._turned:
            return None
        s = self.steps[self.step]
        if s[0] != self.me:
            return None
        self._turned = True
        self.asked = self.step
        return s[1]

    def timeout_ms(self, step=None):
        return self.steps[self.step if step is None else step][2]

    def done(self, now, ok=True):
        # Our request's final status: the step is over for us. A status for
        # a step we already left (on its timeout) changes nothing.
        if self.since is not None and self.asked == self.step:
            self._go(self.step + 1, now)

    def heard(self, now, src, dst):
        # A frame from src to dst reached us (as addressee or by overhearing).
        # Returns the step it was matched to, or None.
        if self.since is None:
            return None
        n = len(self.steps)
        # from the previous step (a late frame: nothing to do) onwards
        for k in range(-1, n - 1):
            j = (self.step + k) % n
            a, r = self.steps[j][0], self.steps[j][1]
            if (src, dst) == (a, r):
                if k < 0:
                    return j
                if r == self.me:
                    self._go(self.step + k + 1, now)  # we were asked: our modem answers
                elif k > 0 or a != self.me:
                    # someone else's request: that step began now
                    if k:
                        self._go(self.step + k, now)
                    self.since = now
                return j
            if (src, dst) == (r, a):
                if k >= 0:
                    self._go(self.step + k + 1, now)
                return j
        return None

    def poll(self, now):
        # Leaves the current step when its timeout has passed; returns the
        # time of the next timeout (None when stopped).
        if self.since is None:
            return None
        end = ticks_add(self.since, self.steps[self.step][2])
        if ticks_diff(now, end) >= 0:
            self.timeouts[self.step] += 1
            self._go(self.step + 1, now)
            end = ticks_add(now, self.steps[self.step][2])
        return end
