# How long node discovery takes: three nodes share one transparent line (a
# FakeUART bus: what one writes, the others receive), each with the
# transparent serial driver at 9600 baud and an advert period P. They power
# on at random moments within one period (deterministic: acomm.prng); a node
# that is off neither steps nor keeps what the line carried meanwhile.
# Measured on virtual time in 10 ms steps: from the last power-on until every
# node has seen every other as available. Worst case over SEEDS runs, in
# seconds and in advert periods. Runtime-independent (virtual time), so it
# runs on CPython only in `acomm bench` (the simulator's clock and fake UART
# are not on its MicroPython path).
try:
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv
except ImportError:  # MicroPython: the runner puts this folder on the path
    from timer import emit_json, quick_argv

from acomm_sim.clock import ManualClock
from acomm.drivers.transparent import TransparentDriver
from acomm.events import AVAILABLE, EV_AVAILABILITY
from acomm_sim.fakeuart import uart_bus
from acomm.node import Node
from acomm.prng import Prng

PER_RUNTIME = ()

NODES = 3
PERIOD_MS = 60000
STEP_MS = 10
SEEDS = 20


def _listener(seen):
    def on_event(ev):
        if ev[0] == EV_AVAILABILITY:
            if ev[3] == AVAILABLE:
                seen.add(ev[2])
            else:
                seen.discard(ev[2])

    return on_event


def discovery_ms(seed, nodes=NODES, period_ms=PERIOD_MS, step_ms=STEP_MS):
    # One run: milliseconds from the last power-on to full discovery.
    clk = ManualClock()
    line = uart_bus(nodes, clock=clk)
    rng = Prng(seed)
    on_at = [rng.below(period_ms // step_ms) * step_ms for _ in range(nodes)]
    last_on = max(on_at)
    names = ["n%d" % (i + 1) for i in range(nodes)]
    running = [None] * nodes
    seen = [set() for _ in range(nodes)]
    t = 0
    limit = last_on + 5 * period_ms
    while t <= limit:
        for i in range(nodes):
            if running[i] is None and t >= on_at[i]:
                line[i].read()  # power-on: the UART starts empty
                node = Node(names[i], i + 1, clk, listener=_listener(seen[i]))
                for j in range(nodes):
                    if j != i:
                        node.names.add(names[j], j + 1)
                node.add_link("radio", TransparentDriver(9600), line[i], advert_period_ms=period_ms)
                running[i] = node
        for node in running:
            if node is not None:
                node.step()
        if t >= last_on:
            done = True
            for s in seen:
                if len(s) < nodes - 1:
                    done = False
                    break
            if done:
                return t - last_on
        clk.advance(step_ms)
        t += step_ms
    raise RuntimeError("seed %d: discovery incomplete after %d ms" % (seed, limit - last_on))


def run(emit, quick=False):
    worst = 0
    for seed in range(1, (2 if quick else SEEDS) + 1):
        d = discovery_ms(seed)
        if d > worst:
            worst = d
    emit("discovery_time_s", worst / 1000, "s")
    emit("discovery_time_periods", worst / PERIOD_MS, "periods")


if __name__ == "__main__":
    run(emit_json, quick_argv())
