# The NPS/USTL AUV rendezvous protocol (seed 002, section IV.C and Table II):
# its ten messages as a Catalog, and the server and survey roles as sans-IO
# state machines the simulator (or a vehicle) drives with received messages,
# local events and `now`. Every entry point returns the list of messages to
# send, as (name, values) pairs; pack() / unpack() turn them into bytes.
#
# The paper's sequence (row numbers of Table II):
#   (1) survey REQ(vehicle, leg, percent) -> server CLOSING, starts approach
#   (2) server at the rendezvous point without contact: QUERY POSIT ->
#       survey answers with an updated REQ; the server re-plans
#   (3) no REQ within the query timeout: server sends QUERY POSIT TIMEOUT
#       and returns to loiter
#   (4) RANGE, from either side at any stage: recorded, changes nothing
#   (5) server at the rendezvous point: INIT RDVZ -> survey CS (transfer
#       has begun)
#   (6) server RDVZ COMMS: acknowledges CS, shadows the survey vehicle
#   (7) survey CC (transfer complete) -> server RDVZ COMPLETED, both resume
# Where the paper is silent (how "cannot establish communications" is
# detected, retries, duplicates) the choices are listed in docs/catalogs.md.

from ..codec.fields import Fixed, UInt
from ..codec.message import Catalog, Message
from ..compat import ticks_add, ticks_diff

# Every message names the survey vehicle of the rendezvous (7 bits, as the
# Seaware compact header's sender address), so the roles work over a
# broadcast link with several survey vehicles and one server.
def _vid():
    return UInt("vehicle_id", 0, 127)


REQ = Message("req", 0, (_vid(), UInt("leg", 0, 255), UInt("percent", 0, 100)))
CLOSING = Message("closing", 1, (_vid(),))
QUERY_POSIT = Message("query_posit", 2, (_vid(),))
QUERY_POSIT_TIMEOUT = Message("query_posit_timeout", 3, (_vid(),))
RANGE = Message("range", 4, (_vid(), Fixed("range_m", 0, 8191, 1)))
INIT_RDVZ = Message("init_rdvz", 5, (_vid(),))
CS = Message("cs", 6, (_vid(),))
RDVZ_COMMS = Message("rdvz_comms", 7, (_vid(),))
CC = Message("cc", 8, (_vid(),))
RDVZ_COMPLETED = Message("rdvz_completed", 9, (_vid(),))

MESSAGES = (REQ, CLOSING, QUERY_POSIT, QUERY_POSIT_TIMEOUT, RANGE, INIT_RDVZ, CS, RDVZ_COMMS, CC, RDVZ_COMPLETED)
CATALOG = Catalog("rendezvous", id_bits=4, messages=MESSAGES)
BY_NAME = {m.name: m for m in MESSAGES}


def pack(msgs):
    # [(name, values), ...] -> bytes (one frame, messages back to back)
    return CATALOG.pack([(BY_NAME[n], v) for n, v in msgs])


def unpack(buf):
    # bytes -> [(name, values), ...]; DecodeError on bad input
    return [(m.name, v) for m, v in CATALOG.unpack(buf)]


class _Role:
    # Shared plumbing: one deadline, an event list the application drains,
    # and the last RANGE heard.
    def __init__(self):
        self.state = "idle"
        self.deadline = None  # ticks of the pending timer, or None
        self.last_range = None
        self._events = []

    def pop_events(self):
        ev = self._events
        self._events = []
        return ev

    def _arm(self, now, ms):
        self.deadline = None if ms is None else ticks_add(now, ms)

    def _expired(self, now):
        return self.deadline is not None and ticks_diff(now, self.deadline) >= 0

    def _goto(self, state, event=None):
        self.state = state
        self.deadline = None
        if event:
            self._events.append(event)


# Server states
LOITER = "loiter"  # idle, waiting for a REQ
APPROACH = "approach"  # CLOSING sent, transiting to the rendezvous point
INIT = "init"  # at the point, INIT RDVZ sent, waiting for CS
QUERY = "query"  # QUERY POSIT sent, waiting for an updated REQ
SHADOW = "shadow"  # RDVZ COMMS sent, following the survey until CC


class ServerRole(_Role):
    # The server vehicle (ARIES in the paper). The application plans the
    # approach from `target`, `leg`, `percent` (events "closing" and
    # "replan") and calls arrived(now) at the rendezvous point.
    #
    # init_timeout_ms: how long INIT RDVZ may go unanswered before the
    #   server decides it "cannot establish communications" (row 2).
    # query_timeout_ms: the QUERY POSIT timeout of row 3.
    # transfer_timeout_ms: optional bound on shadowing without a CC.
    def __init__(self, init_timeout_ms=60000, query_timeout_ms=120000, transfer_timeout_ms=None):
        _Role.__init__(self)
        self.state = LOITER
        self.init_timeout_ms = init_timeout_ms
        self.query_timeout_ms = query_timeout_ms
        self.transfer_timeout_ms = transfer_timeout_ms
        self.target = None  # vehicle id of the rendezvous in progress
        self.leg = None
        self.percent = None
        self._last_done = None  # vehicle whose rendezvous completed last

    def _to(self, name):
        return [(name, {"vehicle_id": self.target})]

    def on_message(self, now, name, values):
        vid = values.get("vehicle_id") if values else None
        if name == "range":
            self.last_range = values["range_m"]
            return []
        st = self.state
        if st == LOITER:
            if name == "req":
                self.target = vid
                self.leg = values["leg"]
                self.percent = values["percent"]
                self._goto(APPROACH, "closing")
                return self._to("closing")
            if name == "cc" and vid == self._last_done:
                # our RDVZ COMPLETED was lost and the survey repeats CC
                return self._to("rdvz_completed")
            return []
        if vid != self.target:
            return []  # one rendezvous at a time; others are ignored
        if name == "req":
            self.leg = values["leg"]
            self.percent = values["percent"]
            if st == QUERY:
                # row 2: the answer to QUERY POSIT; approach again
                self._goto(APPROACH, "replan")
                return []
            if st == SHADOW:
                return []
            # the survey repeats REQ: our CLOSING was lost
            self._events.append("replan")
            return self._to("closing")
        if name == "cs":
            if st != SHADOW:
                # row 5/6: transfer has begun; a CS that arrives after the
                # INIT timeout fired still proves contact
                self._goto(SHADOW, "transfer")
                self._arm(now, self.transfer_timeout_ms)
            return self._to("rdvz_comms")
        if name == "cc":
            # row 7 (also when CS was lost: the survey says it is done)
            self._last_done = self.target
            self._goto(LOITER, "completed")
            return self._to("rdvz_completed")
        return []

    def arrived(self, now):
        # The planner reached the expected rendezvous location (row 5).
        if self.state != APPROACH:
            return []
        self._goto(INIT)
        self._arm(now, self.init_timeout_ms)
        return self._to("init_rdvz")

    def poll(self, now):
        if not self._expired(now):
            return []
        st = self.state
        if st == INIT:
            # row 2: no contact at the rendezvous point
            self._goto(QUERY)
            self._arm(now, self.query_timeout_ms)
            return self._to("query_posit")
        if st == QUERY:
            # row 3: give up, tell the survey vehicle, loiter
            out = self._to("query_posit_timeout")
            self._goto(LOITER, "aborted")
            return out
        if st == SHADOW:
            self._goto(LOITER, "transfer_timeout")
        return []


# Survey states
IDLE = "idle"  # surveying, no rendezvous
REQUESTING = "requesting"  # REQ sent, waiting for CLOSING
WAITING = "waiting"  # CLOSING heard, the server approaches
STARTING = "starting"  # CS sent, transfer running, waiting for RDVZ COMMS
TRANSFER = "transfer"  # RDVZ COMMS heard: the server shadows us
COMPLETING = "completing"  # CC sent, waiting for RDVZ COMPLETED


class SurveyRole(_Role):
    # The survey vehicle (Isurus in the paper). It keeps surveying; the
    # application reports mission progress with set_progress(), starts a
    # rendezvous with request(), begins the data upload on event "transfer"
    # and calls transfer_done() when the upload is complete.
    #
    # req_retry_ms / req_tries: REQ is repeated until CLOSING, then the
    #   request is abandoned (event "no_answer").
    # wait_timeout_ms: optional bound on waiting for the server after
    #   CLOSING (covers a lost QUERY POSIT TIMEOUT); None waits forever.
    # cc_retry_ms / cc_tries: CC is repeated until RDVZ COMPLETED (event
    #   "unacknowledged" when the tries run out; the data is uploaded anyway).
    def __init__(self, vehicle_id, req_retry_ms=30000, req_tries=3, wait_timeout_ms=None, cc_retry_ms=30000, cc_tries=3):
        _Role.__init__(self)
        self.state = IDLE
        self.vehicle_id = vehicle_id
        self.req_retry_ms = req_retry_ms
        self.req_tries = req_tries
        self.wait_timeout_ms = wait_timeout_ms
        self.cc_retry_ms = cc_retry_ms
        self.cc_tries = cc_tries
        self.leg = 0
        self.percent = 0
        self._tries = 0

    def set_progress(self, leg, percent):
        self.leg = leg
        self.percent = percent

    def _req(self):
        return [("req", {"vehicle_id": self.vehicle_id, "leg": self.leg, "percent": self.percent})]

    def _msg(self, name):
        return [(name, {"vehicle_id": self.vehicle_id})]

    def request(self, now, leg=None, percent=None):
        # Row 1: ask the server for a rendezvous (only when idle).
        if self.state != IDLE:
            return []
        if leg is not None:
            self.set_progress(leg, percent)
        self._goto(REQUESTING)
        self._tries = 1
        self._arm(now, self.req_retry_ms)
        return self._req()

    def transfer_done(self, now):
        # Row 7: the upload is complete.
        if self.state not in (STARTING, TRANSFER):
            return []
        self._goto(COMPLETING)
        self._tries = 1
        self._arm(now, self.cc_retry_ms)
        return self._msg("cc")

    def on_message(self, now, name, values):
        if not values or values.get("vehicle_id") != self.vehicle_id:
            return []
        if name == "range":
            self.last_range = values["range_m"]
            return []
        st = self.state
        if st == IDLE:
            return []  # nothing of ours is in progress
        if name == "query_posit_timeout":
            self._goto(IDLE, "aborted")
            return []
        if name == "closing":
            if st == REQUESTING:
                self._goto(WAITING, "closing")
                self._arm(now, self.wait_timeout_ms)
            return []
        if name == "query_posit":
            # row 2: answer with our current position along the mission
            # (a QUERY POSIT in STARTING means our CS was lost: the upload
            # goes on, and the next INIT RDVZ gets the CS again)
            if st == REQUESTING:
                self._goto(WAITING, "closing")  # only an accepted REQ is queried
                self._arm(now, self.wait_timeout_ms)
            if st in (REQUESTING, WAITING, STARTING):
                return self._req()
            return []
        if name == "init_rdvz":
            if st in (REQUESTING, WAITING):
                self._goto(STARTING, "transfer")
                return self._msg("cs")
            if st in (STARTING, TRANSFER):
                return self._msg("cs")  # the server did not hear our CS
            return []
        if name == "rdvz_comms":
            if st == STARTING:
                self._goto(TRANSFER, "shadowed")
            return []
        if name == "rdvz_completed":
            if st == COMPLETING:
                self._goto(IDLE, "completed")
            return []
        return []

    def poll(self, now):
        if not self._expired(now):
            return []
        st = self.state
        if st == REQUESTING:
            if self._tries >= self.req_tries:
                self._goto(IDLE, "no_answer")
                return []
            self._tries += 1
            self._arm(now, self.req_retry_ms)
            return self._req()
        if st == COMPLETING:
            if self._tries >= self.cc_tries:
                self._goto(IDLE, "unacknowledged")
                return []
            self._tries += 1
            self._arm(now, self.cc_retry_ms)
            return self._msg("cc")
        if st == WAITING:
            self._goto(IDLE, "wait_timeout")
        return []
