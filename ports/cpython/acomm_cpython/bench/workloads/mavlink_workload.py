# `acomm bench mavlink`: seed 004's teleoperation through `acomm bridge
# mavlink`, a scripted ground station's joystick to a scripted autopilot.
#
#   mavlink_stick_to_autopilot_ms_p50_<profile>, _p95_<profile>
#       a stick step at the GCS -> the first MANUAL_CONTROL at the autopilot
#       that carries it (quantized as the teleop catalog says), from one
#       stick position to another (up, right, down, left). bpsk and
#       fhss: seed 004's packet-modem profiles in the simulated ocean at the
#       seed's river distance (85 m, its calibrated loss curves, teleop
#       bench), both bridges' sides and real nodes with the key, on the
#       simulated clock (mavsim); steps at a random phase (seeded), as an
#       operator moves. seatrac: the real thing in real time, two `acomm
#       emulate seatrac` beacons, two `acomm bridge mavlink` processes, the
#       GCS and autopilot on UDP on loopback (mavpeers).
#       Beside them the seed's own medians (2.0 s BPSK, 2.7 s FHSS).
#   mavlink_failsafe_neutral_ms
#       bpsk: the water goes silent (every packet lost); from the last
#       acoustic packet the vehicle received to the first neutral
#       MANUAL_CONTROL at the autopilot. The goal: the failsafe timeout
#       (5,000 ms, sim_failsafe's setting) + 100 ms.
#   mavlink_acoustic_bytes_per_minute
#       bpsk, steady stick motion (a sine on surge and yaw, 8 s period) at
#       a 50 Hz GCS: the bytes the topside hands its modem per minute
#       (frames with header and authentication tag), against the seed's
#       scheme on the same motion (_seed004_cbor: a 14-byte rmw_desert CBOR
#       command each 0.1 s poll that changed the vector, the teleop bench's
#       count) and the link's capacity (_capacity_bpsk: 400 bit/s).
#   mavlink_pilot_failsafe_trips
#       gaps of ArduSub's FS_PILOT_TIMEOUT (3 s) between MANUAL_CONTROLs at
#       the autopilot over every run while the link was up: 0.
# quick: one short run of each (its figures mean nothing).

import math
import os
import signal
import subprocess
import sys
import tempfile
import time

from acomm.catalog import teleop
from acomm.prng import Prng
from acomm_sim.channel import Channel
from acomm_sim.metrics import median
from acomm_sim.world import World

from .mavsim import SimBridges
from .teleop_workload import LOSS_CURVES, SEED

PER_RUNTIME = ()

RIVER_M = 85.0
FS_PILOT_TIMEOUT_MS = 3000
TOL = 40  # MANUAL_CONTROL units: a value within a quantization step of 1000/15 = 67 is the target
# the seed's sequence (up, right, down, left), each step from the last; a
# return to neutral is never timed, since a vehicle whose failsafe holds
# neutral would count as there at once
STEPS = ((0, 0, 750, 0, 0, 0), (0, 500, 500, 0, 0, 0), (0, 0, 250, 0, 0, 0), (0, -500, 500, 0, 0, 0))


def _pct(xs, q):
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * len(s)))] if s else None


def _quantized(v):
    # the GCS's value -> what the vehicle side sends, through the teleop catalog's own quantizer
    x, y, z, r, s, t = v
    d = teleop.thrust_values((x / 1000.0, y / 1000.0, (z - 500) / 500.0, t / 1000.0, s / 1000.0, r / 1000.0), 0)
    surge, sway, heave, roll, pitch, yaw = teleop.vector_of(d)
    k = lambda a: int(round(a * 1000))  # noqa: E731
    return (k(surge), k(sway), 500 + int(round(heave * 500)), k(yaw), k(pitch), k(roll))


def _matches(got, want):
    return all(abs(g - w) <= TOL for g, w in zip(got, want))


def _trips(manual, until=None):
    n = 0
    for (a, _), (b, _) in zip(manual, manual[1:]):
        if until is not None and b > until:
            break
        if b - a >= FS_PILOT_TIMEOUT_MS:
            n += 1
    return n


# each profile's keep-alive, failsafe timeout and reply wait (ms), as the
# user sets them with --keepalive, --failsafe-timeout and --reply-wait: the
# wait covers a poll's and a state's airtime (FHSS: about 1 s and 1.3 s)
TIMING = {"bpsk": (2000, 5000, 1000), "fhss": (3000, 7500, 2000)}


def _world(profile, seed=1):
    w = World(seed=seed, channel=Channel(seed=seed, loss_curve=LOSS_CURVES[profile]))
    lo = {"advert_period_ms": 3600000}
    top = w.add("topside", 1, profile, position=(0.0, 0.0, 0.5), link_opts=lo)
    veh = w.add("vehicle", 2, profile, position=(RIVER_M, 0.0, 0.5), link_opts=lo)
    w.run(3000)
    return w, top, veh


def sim_latency(profile, steps, seed=1):
    """-> (latencies ms, pilot failsafe trips): `steps` stick steps 6..14 s apart (random phase)."""
    w, top, veh = _world(profile, seed)
    rng = Prng(seed)
    times = []
    t = w.now() + 5000
    for i in range(steps):
        times.append((t, STEPS[i % len(STEPS)]))
        t += 6000 + rng.below(8000)

    def stick(now):
        cur = (0, 0, 500, 0, 0, 0)
        for at, v in times:
            if now >= at:
                cur = v
        return cur

    keepalive, timeout, reply = TIMING[profile]
    sb = SimBridges(w, top, veh, stick, keepalive_ms=keepalive, timeout_ms=timeout, reply_ms=reply)
    w.add_task(sb)
    w.run(t - w.now() + 5000)
    lat = []
    for at, v in times:
        want = _quantized(v)
        hit = next((tt for tt, got in sb.manual if tt >= at and _matches(got, want)), None)
        if hit is not None:
            lat.append(hit - at)
    return lat, _trips(sb.manual), len(times)


def sim_failsafe(profile="bpsk", seed=1, timeout_ms=5000):
    """-> ms from the vehicle's last acoustic packet to neutral at the autopilot after the water goes silent."""
    w, top, veh = _world(profile, seed)
    t0 = w.now()
    sb = SimBridges(w, top, veh, lambda now: (600, 0, 500, 0, 0, 0) if now - t0 > 2000 else (0, 0, 500, 0, 0, 0),
                    timeout_ms=timeout_ms)
    w.add_task(sb)
    w.run(20000)
    w.channel.loss = 1.0
    cut = w.now()
    w.run(timeout_ms + 5000)
    last = max(t for t in sb.received if t <= cut + 3000)
    neutral = next(t for t, v in sb.manual if t > last and v[0] == 0)
    return neutral - last


def sim_bytes(profile="bpsk", seconds=120, seed=1):
    """-> (our bytes per minute, the seed scheme's bytes per minute) of steady stick motion."""
    w, top, veh = _world(profile, seed)
    t0 = w.now()

    def stick(now):
        a = 2 * math.pi * (now - t0) / 8000.0
        return (int(700 * math.sin(a)), 0, 500, int(400 * math.cos(a)), 0, 0)

    sb = SimBridges(w, top, veh, stick)
    w.add_task(sb)
    w.run(seconds * 1000)
    ours = sum(len(p) for p, _ in sb.uplink) * 60.0 / seconds
    # the seed: the joystick polled every 0.1 s, a 14-byte command whenever the vector changed
    prev, n = None, 0
    for k in range(seconds * 10):
        v = stick(t0 + k * 100)
        if v != prev:
            n += 1
            prev = v
    return ours, n * 14 * 60.0 / seconds, _trips(sb.manual)


# -- the emulated SeaTrac beacons, in real time --------------------------------------------
def seatrac_latency(steps, step_s, env=None):
    """-> (latencies ms, pilot failsafe trips): the bridges as processes over `acomm emulate seatrac`."""
    from .mavpeers import Autopilot, GroundStation

    d = tempfile.mkdtemp(prefix="acomm-mavbench-")
    key = os.path.join(d, "key")
    with open(key, "w") as f:
        f.write(os.urandom(16).hex())
    os.chmod(key, 0o600)
    py = [sys.executable, "-m", "acomm_cpython.cli"]
    procs = []
    ap, gcs = Autopilot(), GroundStation()
    ap.start()
    gcs.start()
    try:
        emu = subprocess.Popen(py + ["emulate", "seatrac", "--link", d + "/top", "--address", "1",
                                     "--peer", "2:%s/veh:85" % d], stdout=subprocess.PIPE, text=True, env=env)
        procs.append(emu)
        for _ in range(2):
            emu.stdout.readline()
        common = ["--key-file", key, "--json"]
        veh = subprocess.Popen(py + ["bridge", "mavlink", "--vehicle", "udpout:127.0.0.1:%d" % ap.port,
                                     "--modem", "seatrac:%s/veh" % d] + common, stdout=subprocess.PIPE, text=True,
                               env=env)
        top = subprocess.Popen(py + ["bridge", "mavlink", "--gcs", "udpout:127.0.0.1:%d" % gcs.port,
                                     "--modem", "seatrac:%s/top" % d] + common, stdout=subprocess.PIPE, text=True,
                               env=env)
        procs += [veh, top]
        for p in (veh, top):
            line = p.stdout.readline()
            if '"ready"' not in line:
                raise RuntimeError("bridge did not start: %r" % line)
        time.sleep(6.0)  # the start-up states and the first poll go by
        t_start = time.monotonic()
        lat = []
        for i in range(steps):
            v = STEPS[i % len(STEPS)]
            want = _quantized(v)
            t = time.monotonic()
            gcs.move(*v)
            end = t + step_s
            while time.monotonic() < end:
                hit = next((tt for tt, got in ap.manual_since(t) if _matches(got, want)), None)
                if hit is not None:
                    lat.append((hit - t) * 1000.0)
                    break
                time.sleep(0.02)
            time.sleep(max(0.0, end - time.monotonic()))
        manual = [(int(tt * 1000), v) for tt, v in ap.manual_since(t_start)]
        return lat, _trips(manual), steps
    finally:
        for p in procs[::-1]:
            p.send_signal(signal.SIGTERM)
        for p in procs[::-1]:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
        ap.stop()
        gcs.stop()


def run(emit, quick=False):
    trips = 0
    for profile in ("bpsk", "fhss"):
        lat, tr, n = sim_latency(profile, 4 if quick else 60)
        trips += tr
        emit("mavlink_stick_to_autopilot_ms_p50_" + profile, median(lat), "ms")
        emit("mavlink_stick_to_autopilot_ms_p95_" + profile, _pct(lat, 0.95), "ms")
        emit("mavlink_stick_delivered_percent_" + profile, 100.0 * len(lat) / n, "%")
        emit("mavlink_stick_to_autopilot_ms_p50_%s_seed004" % profile, median(SEED[("river", profile)][1]), "ms")
    lat, tr, n = seatrac_latency(2 if quick else 16, 8.0)
    trips += tr
    emit("mavlink_stick_to_autopilot_ms_p50_seatrac", median(lat) if lat else None, "ms")
    emit("mavlink_stick_to_autopilot_ms_p95_seatrac", _pct(lat, 0.95), "ms")
    emit("mavlink_stick_delivered_percent_seatrac", 100.0 * len(lat) / n, "%")
    emit("mavlink_failsafe_neutral_ms", sim_failsafe(), "ms")
    ours, seed, tr = sim_bytes(seconds=20 if quick else 300)
    trips += tr
    emit("mavlink_acoustic_bytes_per_minute", round(ours, 1), "bytes/min")
    emit("mavlink_acoustic_bytes_per_minute_seed004_cbor", round(seed, 1), "bytes/min")
    emit("mavlink_acoustic_bytes_per_minute_capacity_bpsk", 400 * 60 / 8.0, "bytes/min")
    emit("mavlink_pilot_failsafe_trips", trips, "count")
