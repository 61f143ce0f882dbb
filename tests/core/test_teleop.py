# Teleoperation (seed 004): the atomic thrust message, the event-triggered
# sender with its heartbeat, and the vehicle-side failsafe, on a manual
# clock that crosses the 2**30 tick wrap. Plain functions, bare asserts.

from acomm.catalog import teleop as T
from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from checks import near, raises

Z = T.NEUTRAL


def _wire(msg):
    # through the codec and back: (name, values)
    m = T.THRUST if msg[0] == "thrust" else T.HEARTBEAT
    (got, v), = T.CATALOG.unpack(T.CATALOG.pack([(m, msg[1])]))
    return got.name, v


def _vec(values):
    return T.vector_of(values)


def _close(a, b):
    # decoded thrust equals the quantized command up to float rounding
    return len(a) == len(b) and all(abs(a[i] - b[i]) < near(2) for i in range(len(a)))


def test_sizes():
    assert T.THRUST.max_bits == T.THRUST.min_bits == 6 * 5 + 4
    assert T.CATALOG.bits(T.THRUST) == 36 and T.CATALOG.bits(T.HEARTBEAT) == 6
    assert len(T.CATALOG.pack([(T.THRUST, T.thrust_values(Z, 0))])) == 5
    assert len(T.CATALOG.pack([(T.HEARTBEAT, {"seq": 15})])) == 1


def test_thrust_boundaries_round_trip_exactly():
    s = T.RES
    for v in (-1.0, -1.0 + s, -s, 0.0, s, 1.0 - s, 1.0):
        for i in range(6):
            vec = [0.0] * 6
            vec[i] = v
            for seq in (0, 15):
                name, out = _wire(("thrust", T.thrust_values(vec, seq)))
                assert name == "thrust" and out["seq"] == seq
                got = _vec(out)
                for k in range(6):
                    assert abs(got[k] - vec[k]) < near(2), (v, i, got)
    # neutral is exact
    assert _close(_vec(_wire(("thrust", T.thrust_values(Z, 3)))[1]), Z)


def test_thrust_random_round_trip_within_half_step():
    rng = Prng(4)
    for _ in range(300):
        vec = [rng.below(20001) / 10000 - 1 for _ in range(6)]
        got = _vec(_wire(("thrust", T.thrust_values(vec, rng.below(16))))[1])
        for k in range(6):
            assert abs(got[k] - vec[k]) <= T.RES / 2 + near(2)


def test_thrust_strict_and_clamped():
    v = T.thrust_values(Z, 0)
    v["yaw"] = 1.5
    raises(EncodeError, T.CATALOG.pack, [(T.THRUST, v)])  # the codec is strict
    # the helpers clamp: a keymap projection may exceed full scale
    assert T.thrust_values((2.0, -3.0, 0, 0, 0, 0), 0)["surge"] == 1.0
    raises(EncodeError, T.thrust_values, (0, 0, 0), 0)
    raises(EncodeError, T.thrust_values, (float("nan"), 0, 0, 0, 0, 0), 0)


def test_random_bytes_raise_only_decode_error():
    # any other exception fails the test; both outcomes must occur, and what
    # decodes is messages of the catalog with their values
    rng = Prng(44)
    decoded = refused = 0
    for _ in range(1000):
        try:
            msgs = T.CATALOG.unpack(bytes(rng.below(256) for _ in range(rng.below(8))))
        except DecodeError:
            refused += 1
            continue
        decoded += 1
        for m, values in msgs:
            assert T.CATALOG.by_id(m.msg_id) is m and isinstance(values, dict)
    assert decoded > 10 and refused > 10, (decoded, refused)


def test_sender_event_triggered_beyond_threshold():
    clock = ManualClock(TICKS_MAX - 50)
    s = T.TeleopSender(threshold=0.1, heartbeat_ms=5000)
    first = s.update(clock(), Z)
    assert first[0] == "thrust" and first[1]["seq"] == 1  # the first always goes
    clock.advance(100)
    # 1 level (0.067) is within the threshold; 2 levels (0.133) are beyond
    assert s.update(clock(), (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)) is None
    assert s.update(clock(), (1 / 15, 0, 0, 0, 0, 0)) is None
    out = s.update(clock(), (2 / 15, 0, 0, 0, 0, 0))
    assert out[0] == "thrust" and abs(out[1]["surge"] - 2 / 15) < near(2) and out[1]["seq"] == 2
    # compared with the last vector SENT: small steps cannot creep
    assert s.update(clock(), (3 / 15, 0, 0, 0, 0, 0)) is None
    assert s.update(clock(), (4 / 15, 0, 0, 0, 0, 0))[1]["surge"] == 4 / 15
    # any axis counts
    assert s.update(clock(), (4 / 15, 0, 0, 0, 0, -0.2))[1]["yaw"] == -3 / 15
    # back to exact neutral is always sent, even below the threshold
    s2 = T.TeleopSender(threshold=0.5, heartbeat_ms=5000)
    s2.update(clock(), (0.2, 0, 0, 0, 0, 0))
    assert s2.update(clock(), (0.3, 0, 0, 0, 0, 0)) is None
    assert s2.update(clock(), (0.02, 0, 0, 0, 0, 0))[1]["surge"] == 0.0
    assert s2.update(clock(), Z) is None  # already neutral
    # threshold 0: every quantized change, nothing else
    s3 = T.TeleopSender(threshold=0, heartbeat_ms=5000)
    s3.update(clock(), Z)
    assert s3.update(clock(), (0.01, 0, 0, 0, 0, 0)) is None  # same level
    assert s3.update(clock(), (0.05, 0, 0, 0, 0, 0)) is not None
    raises(EncodeError, s3.update, clock(), (0, 0))


def test_sender_seq_wraps():
    s = T.TeleopSender(threshold=0, heartbeat_ms=1000)
    seqs = []
    for i in range(20):
        seqs.append(s.update(0, (((i % 2) * 2 - 1) * 0.5, 0, 0, 0, 0, 0))[1]["seq"])
    assert seqs[:16] == list(range(1, 16)) + [0] and seqs[16] == 1


def test_heartbeat_period_across_wrap():
    clock = ManualClock(TICKS_MAX - 2500)
    s = T.TeleopSender(threshold=0.1, heartbeat_ms=1000)
    hb = s.poll(clock())  # nothing sent yet: announce at once
    assert hb == ("heartbeat", {"seq": 0})
    assert s.poll(clock()) is None
    sent = []
    for _ in range(60):  # 6 s in steps of 100 ms, through the wrap
        clock.advance(100)
        out = s.poll(clock())
        if out:
            sent.append(out)
    assert len(sent) == 6 and all(m == ("heartbeat", {"seq": 0}) for m in sent)
    # a command resets the period and is named by later heartbeats
    clock.advance(500)
    cmd = s.update(clock(), (0.5, 0, 0, 0, 0, 0))
    clock.advance(999)
    assert s.poll(clock()) is None
    clock.advance(1)
    assert s.poll(clock()) == ("heartbeat", {"seq": cmd[1]["seq"]})
    # steady state: unchanged updates send nothing, heartbeats keep going
    n = 0
    for _ in range(50):
        clock.advance(100)
        assert s.update(clock(), (0.5, 0, 0, 0, 0, 0)) is None
        if s.poll(clock()):
            n += 1
    assert n == 5
    assert _wire(s.poll(ManualClock(clock()).advance(1000)))[0] == "heartbeat"


def test_failsafe_trips_after_timeout_and_recovers():
    clock = ManualClock(TICKS_MAX - 3000)
    f = T.Failsafe(timeout_ms=5000)
    assert f.poll(clock()) == Z and not f.tripped  # nothing yet: neutral, no trip
    clock.advance(100000)
    assert f.poll(clock()) == Z and f.pop_events() == []
    cmd = (0.5, 0, -0.2, 0, 0, 1.0)
    assert f.on_command(clock(), cmd, 1)
    assert f.poll(clock()) == cmd
    clock.advance(4999)
    assert f.poll(clock()) == cmd and not f.tripped
    clock.advance(1)  # across the tick wrap
    assert f.poll(clock()) == Z and f.tripped and f.reason == "timeout"
    assert f.pop_events() == ["tripped"]
    clock.advance(10000)
    assert f.poll(clock()) == Z and f.pop_events() == []  # tripped once
    # a heartbeat says the link is back, but not what to do: stay neutral
    f.on_heartbeat(clock(), 1)
    assert f.poll(clock()) == Z and f.tripped
    # a valid command recovers
    assert f.on_command(clock(), (0.2, 0, 0, 0, 0, 0), 2)
    assert f.poll(clock()) == (0.2, 0, 0, 0, 0, 0) and not f.tripped
    assert f.pop_events() == ["recovered"]


def test_failsafe_heartbeats_keep_the_command():
    clock = ManualClock()
    f = T.Failsafe(timeout_ms=5000)
    f.on_command(clock(), (0.4, 0, 0, 0, 0, 0), 7)
    for _ in range(10):
        clock.advance(4000)
        f.on_heartbeat(clock(), 7)
        assert f.poll(clock()) == (0.4, 0, 0, 0, 0, 0)
    assert not f.tripped and f.pop_events() == []


def test_failsafe_detects_a_missed_command():
    clock = ManualClock()
    f = T.Failsafe(timeout_ms=5000)
    f.on_command(clock(), (0.4, 0, 0, 0, 0, 0), 7)
    clock.advance(1000)
    f.on_heartbeat(clock(), 8)  # command 8 (maybe "stop") never arrived
    assert f.poll(clock()) == Z and f.tripped and f.reason == "missed_command"
    assert f.pop_events() == ["tripped"]
    f.on_command(clock(), Z, 8)
    assert not f.tripped and f.pop_events() == ["recovered"]


def test_failsafe_rejects_invalid_commands():
    clock = ManualClock()
    f = T.Failsafe(timeout_ms=1000)
    f.on_command(clock(), (0.1, 0, 0, 0, 0, 0))
    clock.advance(600)
    for bad in ((1.5, 0, 0, 0, 0, 0), (0, 0, 0), (float("nan"), 0, 0, 0, 0, 0)):
        assert not f.on_command(clock(), bad)
    clock.advance(400)  # invalid input did not keep it alive
    assert f.poll(clock()) == Z and f.tripped
    assert not f.on_message(clock(), "lights", {})


def test_sender_to_failsafe_through_the_wire():
    # The seed's input sequence (IV.E): neutral, up, neutral, right, ... with
    # 10 s holds, sampled every 100 ms; one command lost, then the link dies.
    clock = ManualClock(TICKS_MAX - 20000)
    s = T.TeleopSender(threshold=0.1, heartbeat_ms=3000)
    f = T.Failsafe(timeout_ms=10000)
    seq = (Z, (0, 0, 1.0, 0, 0, 0), Z, (0, 1.0, 0, 0, 0, 0), Z, (0, 0, -1.0, 0, 0, 0), Z, (0, -1.0, 0, 0, 0, 0))
    commands = beats = 0
    applied = []
    for i in range(len(seq)):
        for _ in range(100):
            clock.advance(100)
            for msg in (s.update(clock(), seq[i]), s.poll(clock())):
                if msg is None:
                    continue
                if msg[0] == "thrust":
                    commands += 1
                else:
                    beats += 1
                name, v = _wire(msg)
                f.on_message(clock(), name, v)
            applied.append(f.poll(clock()))
        assert _close(applied[-1], seq[i])
    assert commands == 8 and beats == 8 * 3
    assert not f.tripped
    # lose the next command; the following heartbeat reveals it
    clock.advance(100)
    lost = s.update(clock(), (0.6, 0, 0, 0, 0, 0))
    assert lost[0] == "thrust"
    clock.advance(3000)
    f.on_message(clock(), *_wire(s.poll(clock())))
    assert f.poll(clock()) == Z and f.reason == "missed_command"
    # the link goes silent: still neutral; a new command brings it back
    clock.advance(60000)
    assert f.poll(clock()) == Z
    f.on_message(clock(), *_wire(s.update(clock(), (0, 0, 0, 0, 0, 0.6))))
    assert _close(f.poll(clock()), (0, 0, 0, 0, 0, 0.6)) and not f.tripped
