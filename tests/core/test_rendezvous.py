# Rendezvous protocol (seed 002, Table II): the catalog, and the server and
# survey roles exchanging every message through pack/unpack, with a manual
# clock. Plain functions with bare asserts (pytest and mp_runtests.py).

from acomm.catalog import rendezvous as R
from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises

SURVEY_ID = 17


def _wire(msgs):
    # every message really crosses the wire: pack, unpack, names back
    if not msgs:
        return []
    return R.unpack(R.pack(msgs))


def _feed(role, now, msgs, log=None):
    # deliver msgs to role; returns its replies (already through the wire)
    out = []
    for name, values in _wire(msgs):
        if log is not None:
            log.append(name)
        out += role.on_message(now, name, values)
    return out


def _pair(start=0, **kw):
    clock = ManualClock(start)
    server = R.ServerRole(init_timeout_ms=60000, query_timeout_ms=120000, transfer_timeout_ms=kw.pop("transfer_timeout_ms", None))
    survey = R.SurveyRole(SURVEY_ID, **kw)
    survey.set_progress(3, 40)
    return clock, server, survey


def _to_waiting(clock, server, survey, log):
    out = survey.request(clock())
    back = _feed(server, clock(), out, log)
    assert _feed(survey, clock(), back, log) == []
    assert server.state == R.APPROACH and survey.state == R.WAITING


def test_catalog_ids_and_bits():
    names = ("req", "closing", "query_posit", "query_posit_timeout", "range", "init_rdvz", "cs", "rdvz_comms", "cc", "rdvz_completed")
    for i in range(10):
        assert R.MESSAGES[i].name == names[i] and R.MESSAGES[i].id == i
    assert R.CATALOG.id_bits == 4
    assert R.CATALOG.bits(R.REQ) == 4 + 7 + 8 + 7
    assert R.CATALOG.bits(R.RANGE) == 4 + 7 + 13
    for m in R.MESSAGES:
        if m not in (R.REQ, R.RANGE):
            assert R.CATALOG.bits(m) == 11


def test_message_boundaries_round_trip():
    for vid in (0, 1, 126, 127):
        for leg, pct in ((0, 0), (1, 1), (254, 99), (255, 100)):
            got = R.unpack(R.pack([("req", {"vehicle_id": vid, "leg": leg, "percent": pct})]))
            assert got == [("req", {"vehicle_id": vid, "leg": leg, "percent": pct})]
        for r in (0, 1, 8190, 8191):
            (name, v), = R.unpack(R.pack([("range", {"vehicle_id": vid, "range_m": r})]))
            assert name == "range" and v["vehicle_id"] == vid and abs(v["range_m"] - r) <= 0.5
        for m in R.MESSAGES:
            if len(m.fields) == 1:
                assert R.unpack(R.pack([(m.name, {"vehicle_id": vid})])) == [(m.name, {"vehicle_id": vid})]
    raises(EncodeError, R.pack, [("req", {"vehicle_id": 128, "leg": 0, "percent": 0})])
    raises(EncodeError, R.pack, [("req", {"vehicle_id": 1, "leg": 0, "percent": 101})])


def test_several_messages_in_one_frame():
    msgs = [("cs", {"vehicle_id": 5}), ("req", {"vehicle_id": 5, "leg": 9, "percent": 50}), ("cc", {"vehicle_id": 5})]
    assert R.unpack(R.pack(msgs)) == msgs


def test_random_bytes_raise_only_decode_error():
    # any other exception fails the test; both outcomes must occur, and what
    # decodes is the catalog's messages with their values
    rng = Prng(4)
    decoded = refused = 0
    for _ in range(1000):
        data = bytes(rng.below(256) for _ in range(rng.below(8)))
        try:
            msgs = R.unpack(data)
        except DecodeError:
            refused += 1
            continue
        decoded += 1
        for name, values in msgs:
            assert name in R.BY_NAME and isinstance(values, dict)
    assert decoded > 10 and refused > 10, (decoded, refused)


def _happy_path(start):
    clock, server, survey = _pair(start)
    log = []
    # (1) REQ / CLOSING
    out = survey.request(clock(), 4, 25)
    assert survey.state == R.REQUESTING
    back = _feed(server, clock(), out, log)
    assert server.state == R.APPROACH and server.target == SURVEY_ID
    assert (server.leg, server.percent) == (4, 25)
    assert server.pop_events() == ["closing"]
    assert _feed(survey, clock(), back, log) == []
    assert survey.state == R.WAITING and survey.pop_events() == ["closing"]
    # the approach takes a while; nothing times out on either side
    clock.advance(600000)
    assert server.poll(clock()) == [] and survey.poll(clock()) == []
    # (5) INIT RDVZ / CS
    out = server.arrived(clock())
    assert server.state == R.INIT
    back = _feed(survey, clock(), out, log)
    assert survey.state == R.STARTING and survey.pop_events() == ["transfer"]
    # (6) RDVZ COMMS
    back = _feed(server, clock(), back, log)
    assert server.state == R.SHADOW and server.pop_events() == ["transfer"]
    assert _feed(survey, clock(), back, log) == []
    assert survey.state == R.TRANSFER and survey.pop_events() == ["shadowed"]
    # (4) RANGE from either side changes nothing
    rng = [("range", {"vehicle_id": SURVEY_ID, "range_m": 42})]
    assert _feed(survey, clock(), rng) == [] and _feed(server, clock(), rng) == []
    assert survey.last_range == 42 and server.last_range == 42
    assert survey.state == R.TRANSFER and server.state == R.SHADOW
    clock.advance(300000)
    assert server.poll(clock()) == [] and survey.poll(clock()) == []
    # (7) CC / RDVZ COMPLETED
    out = survey.transfer_done(clock())
    assert survey.state == R.COMPLETING
    back = _feed(server, clock(), out, log)
    assert server.state == R.LOITER and server.pop_events() == ["completed"]
    assert _feed(survey, clock(), back, log) == []
    assert survey.state == R.IDLE and survey.pop_events() == ["completed"]
    assert log == ["req", "closing", "init_rdvz", "cs", "rdvz_comms", "cc", "rdvz_completed"]
    assert server.deadline is None and survey.deadline is None


def test_happy_path():
    _happy_path(0)


def test_happy_path_across_tick_wrap():
    _happy_path(TICKS_MAX - 300000)


def test_query_posit_then_updated_req():
    # (2): no CS at the rendezvous point -> QUERY POSIT -> updated REQ
    clock, server, survey = _pair(TICKS_MAX - 1000)
    log = []
    _to_waiting(clock, server, survey, log)
    server.arrived(clock())  # INIT RDVZ lost
    clock.advance(59999)
    assert server.poll(clock()) == []
    clock.advance(1)
    out = server.poll(clock())
    assert server.state == R.QUERY and [n for n, v in out] == ["query_posit"]
    survey.set_progress(5, 10)
    back = _feed(survey, clock(), out, log)
    assert survey.state == R.WAITING
    assert back == [("req", {"vehicle_id": SURVEY_ID, "leg": 5, "percent": 10})]
    assert _feed(server, clock(), back, log) == []
    assert server.state == R.APPROACH and (server.leg, server.percent) == (5, 10)
    assert server.pop_events() == ["closing", "replan"]
    # and the rendezvous then proceeds normally
    back = _feed(survey, clock(), server.arrived(clock()), log)
    _feed(survey, clock(), _feed(server, clock(), back, log), log)
    assert server.state == R.SHADOW and survey.state == R.TRANSFER
    assert log == ["req", "closing", "query_posit", "req", "init_rdvz", "cs", "rdvz_comms"]


def test_query_posit_timeout():
    # (3): no REQ after QUERY POSIT -> QUERY POSIT TIMEOUT, back to loiter
    clock, server, survey = _pair()
    log = []
    _to_waiting(clock, server, survey, log)
    server.arrived(clock())
    clock.advance(60000)
    assert [n for n, v in server.poll(clock())] == ["query_posit"]  # lost
    clock.advance(119999)
    assert server.poll(clock()) == []
    clock.advance(1)
    out = server.poll(clock())
    assert out == [("query_posit_timeout", {"vehicle_id": SURVEY_ID})]
    assert server.state == R.LOITER and server.pop_events() == ["closing", "aborted"]
    assert _feed(survey, clock(), out) == []
    assert survey.state == R.IDLE and survey.pop_events() == ["closing", "aborted"]
    # the server takes a new request afterwards
    assert [n for n, v in _feed(server, clock(), survey.request(clock()))] == ["closing"]


def test_survey_repeats_req_then_gives_up():
    clock, server, survey = _pair(req_retry_ms=30000, req_tries=3)
    assert len(survey.request(clock())) == 1
    assert survey.request(clock()) == []  # only one request at a time
    sent = 1
    for _ in range(2):
        clock.advance(29999)
        assert survey.poll(clock()) == []
        clock.advance(1)
        out = survey.poll(clock())
        assert [n for n, v in out] == ["req"]
        sent += 1
    clock.advance(30000)
    assert survey.poll(clock()) == []
    assert survey.state == R.IDLE and survey.pop_events() == ["no_answer"] and sent == 3


def test_lost_closing_is_repeated():
    clock, server, survey = _pair()
    out = survey.request(clock())
    _feed(server, clock(), out)  # CLOSING lost
    clock.advance(30000)
    again = survey.poll(clock())
    back = _feed(server, clock(), again)
    assert back == [("closing", {"vehicle_id": SURVEY_ID})] and server.state == R.APPROACH
    _feed(survey, clock(), back)
    assert survey.state == R.WAITING and survey.deadline is None


def test_lost_cs_recovers_through_query_posit():
    clock, server, survey = _pair()
    log = []
    _to_waiting(clock, server, survey, log)
    _feed(survey, clock(), server.arrived(clock()))  # survey sends CS: lost
    assert survey.state == R.STARTING
    clock.advance(60000)
    q = server.poll(clock())
    back = _feed(survey, clock(), q)
    assert [n for n, v in back] == ["req"] and survey.state == R.STARTING  # upload goes on
    _feed(server, clock(), back)
    assert server.state == R.APPROACH
    cs = _feed(survey, clock(), server.arrived(clock()))
    assert [n for n, v in cs] == ["cs"]
    ack = _feed(server, clock(), cs)
    assert [n for n, v in ack] == ["rdvz_comms"] and server.state == R.SHADOW
    _feed(survey, clock(), ack)
    assert survey.state == R.TRANSFER


def test_lost_rdvz_comms_and_late_cs():
    clock, server, survey = _pair()
    _to_waiting(clock, server, survey, [])
    cs = _feed(survey, clock(), server.arrived(clock()))
    _feed(server, clock(), cs)  # RDVZ COMMS lost
    assert server.state == R.SHADOW and survey.state == R.STARTING
    # the survey may finish while never hearing RDVZ COMMS
    out = survey.transfer_done(clock())
    back = _feed(server, clock(), out)
    _feed(survey, clock(), back)
    assert server.state == R.LOITER and survey.state == R.IDLE


def test_lost_rdvz_completed():
    clock, server, survey = _pair(cc_retry_ms=20000, cc_tries=3)
    _to_waiting(clock, server, survey, [])
    _feed(survey, clock(), _feed(server, clock(), _feed(survey, clock(), server.arrived(clock()))))
    _feed(server, clock(), survey.transfer_done(clock()))  # RDVZ COMPLETED lost
    assert server.state == R.LOITER and survey.state == R.COMPLETING
    clock.advance(20000)
    cc = survey.poll(clock())
    assert [n for n, v in cc] == ["cc"]
    back = _feed(server, clock(), cc)  # a loitering server acknowledges again
    assert [n for n, v in back] == ["rdvz_completed"] and server.state == R.LOITER
    _feed(survey, clock(), back)
    assert survey.state == R.IDLE and survey.pop_events()[-1] == "completed"


def test_cc_unacknowledged_gives_up():
    clock, server, survey = _pair(cc_retry_ms=20000, cc_tries=2)
    _to_waiting(clock, server, survey, [])
    _feed(survey, clock(), _feed(server, clock(), _feed(survey, clock(), server.arrived(clock()))))
    survey.transfer_done(clock())
    clock.advance(20000)
    assert len(survey.poll(clock())) == 1
    clock.advance(20000)
    assert survey.poll(clock()) == []
    assert survey.state == R.IDLE and survey.pop_events()[-1] == "unacknowledged"


def test_wait_timeout_and_transfer_timeout():
    clock, server, survey = _pair(wait_timeout_ms=900000, transfer_timeout_ms=1800000)
    _to_waiting(clock, server, survey, [])
    clock.advance(899999)
    assert survey.poll(clock()) == [] and survey.state == R.WAITING
    clock.advance(1)
    survey.poll(clock())
    assert survey.state == R.IDLE and survey.pop_events()[-1] == "wait_timeout"
    # the server shadows at most transfer_timeout_ms without a CC
    server.arrived(clock())
    server.on_message(clock(), "cs", {"vehicle_id": SURVEY_ID})
    assert server.state == R.SHADOW
    clock.advance(1800000)
    assert server.poll(clock()) == []
    assert server.state == R.LOITER and server.pop_events()[-1] == "transfer_timeout"


def test_unexpected_messages_are_ignored():
    clock, server, survey = _pair()
    now = clock()
    # nothing in progress: every message but a REQ leaves both roles alone
    for m in R.MESSAGES:
        if m.name in ("req", "range"):
            continue
        v = {"vehicle_id": SURVEY_ID}
        assert survey.on_message(now, m.name, v) == [] and survey.state == R.IDLE
        assert server.on_message(now, m.name, v) == [] and server.state == R.LOITER
    assert survey.on_message(now, "req", {"vehicle_id": SURVEY_ID, "leg": 1, "percent": 1}) == []
    assert server.arrived(now) == [] and survey.transfer_done(now) == []
    assert server.poll(now) == [] and survey.poll(now) == []
    assert server.pop_events() == [] and survey.pop_events() == []
    # a busy server ignores other vehicles; a survey ignores others' messages
    _to_waiting(clock, server, survey, [])
    other = {"vehicle_id": SURVEY_ID + 1}
    assert server.on_message(now, "req", {"vehicle_id": SURVEY_ID + 1, "leg": 0, "percent": 0}) == []
    assert server.on_message(now, "cc", other) == [] and server.target == SURVEY_ID
    for name in ("closing", "query_posit", "query_posit_timeout", "init_rdvz", "rdvz_completed"):
        assert survey.on_message(now, name, other) == [] and survey.state == R.WAITING
    # out of order: RDVZ COMMS / RDVZ COMPLETED before their turn
    mine = {"vehicle_id": SURVEY_ID}
    assert survey.on_message(now, "rdvz_comms", mine) == [] and survey.state == R.WAITING
    assert survey.on_message(now, "rdvz_completed", mine) == [] and survey.state == R.WAITING
    assert survey.on_message(now, "closing", mine) == [] and survey.state == R.WAITING
    assert server.arrived(now) != [] and server.arrived(now) == []  # only once
    assert server.state == R.INIT
