# What a topside node costs while it waits, and how soon it hears: the
# event-driven loop (acomm_cpython.ioloop) against the 5 ms polling loop
# `acomm node` ran before it, measured in one run so the two compare as a
# ratio on a shared machine.
#
#   node_idle_cpu_percent        `acomm node` on an emulated SeaTrac beacon
#                                (acomm emulate, another process), idle
#                                after its start-up: its process CPU time
#                                (/proc, user + system) over SECONDS of wall
#                                time, in percent of one core
#   node_idle_cpu_percent_polling  the same node stepped every 5 ms, as the
#                                old loop did (a child process)
#   node_rx_wakeup_ms_p95        bytes written into a pseudo-terminal by
#                                another thread -> the driver's feed(): the
#                                95th percentile over FRAMES frames, 20 ms
#                                apart, of a node on NodeLoop
#   node_rx_wakeup_ms_p95_polling  the same with the 5 ms polling loop
#   node_idle_steps_per_s        the event-driven node's steps a second
#                                while idle (timer wakes)
# Linux only (/proc and pseudo-terminals). quick: 1 s and 30 frames.

import asyncio
import os
import subprocess
import sys
import tempfile
import threading
import time

PER_RUNTIME = ()

SECONDS = 30.0
FRAMES = 200
GAP_S = 0.02

_POLLING_CHILD = r"""
import sys, time
from acomm.node import Node
from acomm_cpython.modems import add_modem_link
node = Node("buoy", 1)
name, stream, watch = add_modem_link(node, sys.argv[1])
end = time.monotonic() + 15
while not watch.up and time.monotonic() < end:
    node.step(); time.sleep(0.005)
if not watch.up:
    sys.exit("no start-up")
print("ready", flush=True)
while True:
    node.step(); time.sleep(0.005)
"""


def _cpu_s(pid):
    # user + system time of a process, seconds (/proc/PID/stat fields 14, 15)
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _idle_cpu(cmd, env, seconds, settle_s=1.0):
    # percent of one core the process `cmd` takes over `seconds` once it printed a "ready" line
    p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env,
                         text=True)
    try:
        # both children end by themselves when the modem stays silent
        # (acomm node's --startup-timeout, the polling child's 15 s)
        lines = []
        for line in p.stdout:
            lines.append(line)
            if line.startswith("ready"):
                break
        else:
            raise RuntimeError("%s did not start:\n%s" % (cmd[:3], "".join(lines)))
        time.sleep(settle_s)  # its first adverts and status polls go by
        c0, t0 = _cpu_s(p.pid), time.monotonic()
        time.sleep(seconds)
        c1, t1 = _cpu_s(p.pid), time.monotonic()
        return 100.0 * (c1 - c0) / (t1 - t0)
    finally:
        p.kill()
        p.wait(10)
        p.stdout.close()
        p.stdin.close()


def _emulator(place, env):
    a, b = os.path.join(place, "beacon1"), os.path.join(place, "beacon2")
    p = subprocess.Popen([sys.executable, "-m", "acomm_cpython.cli", "emulate", "seatrac", "--link", a, "--address", "1",
                          "--peer", "2:%s:150" % b], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    end = time.monotonic() + 20
    while not os.path.exists(a):
        if p.poll() is not None or time.monotonic() > end:
            p.kill()
            raise RuntimeError("acomm emulate seatrac did not start")
        time.sleep(0.05)
    return p, a


class _Timed:
    # a transparent driver that notes when the bytes of each frame first reach it
    def __init__(self):
        from acomm.drivers.transparent import TransparentDriver

        self.driver = TransparentDriver(baud=115200)
        self.first = {}  # frame index -> perf_counter at its first feed
        inner = self.driver.feed

        def feed(now, data):
            t = time.perf_counter()
            if data:
                self.first.setdefault(data[0], t)
            inner(now, data)

        self.driver.feed = feed


def _writer(fd, frames, sent):
    # another thread, as a modem's bytes come from outside the program
    time.sleep(0.2)
    for i in range(frames):
        sent[i % 256] = time.perf_counter()
        os.write(fd, bytes((i % 256,)) + b"\x55" * 31)
        time.sleep(GAP_S)
        if i % 256 == 255:
            time.sleep(0.05)


def _p95(sent, first):
    lat = sorted((first[i] - sent[i]) * 1000.0 for i in sent if i in first and first[i] >= sent[i])
    if not lat:
        raise RuntimeError("no frame reached the driver")
    return lat[min(len(lat) - 1, int(0.95 * len(lat)))], len(lat)


def _rx_wakeup(frames, polling):
    import serial

    from acomm.node import Node
    from acomm_cpython.ioloop import NodeLoop
    from acomm_cpython.streams import SerialStream

    frames = min(frames, 256)
    master, slave = os.openpty()
    from acomm_cpython.emulate.pty import set_raw

    set_raw(slave)
    stream = SerialStream(serial.Serial(os.ttyname(slave), 115200, timeout=0))
    timed = _Timed()
    node = Node("topside", 1)
    node.add_link("serial", timed.driver, stream)
    sent = {}
    w = threading.Thread(target=_writer, args=(master, frames, sent), daemon=True)
    try:
        if polling:
            w.start()
            end = time.monotonic() + 0.5 + frames * GAP_S * 1.5
            while w.is_alive() and time.monotonic() < end:
                node.step()
                time.sleep(0.005)
            node.step()
        else:
            async def main():
                loop = NodeLoop(node, [stream]).start()
                w.start()
                while w.is_alive():
                    await asyncio.sleep(0.05)
                await asyncio.sleep(0.05)
                loop.close()

            asyncio.run(main())
        w.join(5)
        return _p95(sent, timed.first)[0]
    finally:
        stream.close()
        os.close(master)
        os.close(slave)


def run(emit, quick=False):
    if not sys.platform.startswith("linux"):
        print("note: acomm bench node needs Linux (/proc, pseudo-terminals)", file=sys.stderr)
        return
    seconds = 1.0 if quick else SECONDS
    settle = 0.3 if quick else 1.0
    frames = 30 if quick else FRAMES
    emit("node_rx_wakeup_ms_p95", round(_rx_wakeup(frames, False), 3), "ms")
    emit("node_rx_wakeup_ms_p95_polling", round(_rx_wakeup(frames, True), 3), "ms")
    env = dict(os.environ)
    place = tempfile.mkdtemp(prefix="acomm-bench-node-")
    emu, path = _emulator(place, env)
    try:
        node = [sys.executable, "-m", "acomm_cpython.cli", "node", "--name", "buoy", "--id", "1", "--known", "diver=2",
                "--modem", "seatrac:" + path]
        emit("node_idle_cpu_percent", round(_idle_cpu(node, env, seconds, settle), 3), "%")
        poll = [sys.executable, "-c", _POLLING_CHILD, "seatrac:" + path]
        emit("node_idle_cpu_percent_polling", round(_idle_cpu(poll, env, seconds, settle), 3), "%")
    finally:
        emu.kill()
        emu.wait(10)
