# The simulator's own speed and the MAC schemes under one load: 16 nodes with
# BPSK packet modems (seed 004: 400 bit/s, 12 bytes of modem framing) spread
# over 750 m, each broadcasting a 20-byte telemetry frame every minute for
# one simulated hour, once on TDMA (one slot per node: the frame's airtime,
# 500 ms for propagation, guards of 200 ms) and once on ALOHA (a random
# backoff of up to 16 frame airtimes, the window the load needs). Figures:
#   sim_speedup_16_nodes   simulated seconds per wall second (TDMA run)
#   tdma_collisions, aloha_collisions   copies lost to overlapping arrivals
#   tdma_pdr, aloha_pdr    fraction of (frame, listener) pairs delivered
# Virtual time; runs on CPython in `acomm bench sim`.
import time

from acomm.mac import Aloha, Tdma
from acomm.events import EV_RECEIVED
from acomm_sim.world import World

PER_RUNTIME = ()

NODES = 16
SIM_S = 3600
PERIOD_S = 60
PAYLOAD = 20
BITRATE, FRAMING = 400, 12


def airtime_ms():
    n = PAYLOAD + 5  # raw acomm header (3) and CRC (2); the SLIP ends stay on the serial line
    return ((n + FRAMING) * 8000 + BITRATE - 1) // BITRATE


def run_once(kind, seed=1):
    air = airtime_ms()
    sched = [(i + 1, air + 500 + 400, 200) for i in range(NODES)]
    w = World(seed=seed)
    for i in range(NODES):
        mac = Tdma(sched, i + 1, tx_ms=air) if kind == "tdma" else Aloha(NODES * air, seed=seed * 100 + i)
        w.add("n%d" % (i + 1), i + 1, "bpsk", position=(50.0 * i, 0.0, 10.0), mac=mac,
              link_opts={"advert_period_ms": 600000, "queue_capacity": 8})
    t0 = time.perf_counter()
    sent = 0
    for minute in range(SIM_S // PERIOD_S):
        for sn in w.nodes.values():
            sn.node.send("acoustic", "*", bytes([minute & 0xFF]) * PAYLOAD, PERIOD_S, 5)
            sent += 1
        w.run(PERIOD_S * 1000)
    wall = time.perf_counter() - t0
    rx = sum(1 for sn in w.nodes.values() for e in sn.events if e[0] == EV_RECEIVED)
    return w, wall, rx / (sent * (NODES - 1))


def run(emit):
    w, wall, pdr = run_once("tdma")
    emit("sim_speedup_16_nodes", SIM_S / wall, "x")
    emit("tdma_collisions", w.channel.collided, "copies")
    emit("tdma_pdr", pdr, "ratio")
    w, wall, pdr = run_once("aloha")
    emit("aloha_collisions", w.channel.collided, "copies")
    emit("aloha_pdr", pdr, "ratio")
