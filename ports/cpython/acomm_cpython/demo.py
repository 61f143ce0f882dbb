# `acomm demo`: a surface buoy and a diver's tablet on a noisy serial radio
# link (a FakeUART pair at 1200 baud: 10 % of writes lose a bit, 5 % are lost,
# writes are split and delayed), running the real Node, Link, transparent
# driver and frame codec on a virtual clock. It shows discovery, acknowledged
# telemetry, an alarm overtaking a backlog of chat, and what the CRC caught.
# (The simulated ocean with acoustic modems replaces this scenario later.)
import json

from acomm.clock import ManualClock
from acomm.drivers.transparent import TransparentDriver
from acomm.events import (
    AVAIL_NAMES,
    EV_AVAILABILITY,
    EV_RECEIVED,
    EV_STATUS,
    STATUS_NAMES,
    TRANSMITTING,
    is_final,
)
from acomm.fakeuart import uart_pair
from acomm.link import BROADCAST
from acomm.node import Node

PRIORITY_NAMES = {1: "alarm", 2: "telemetry", 12: "chat"}


def main(args):
    clock = ManualClock()
    a, b = uart_pair(clock=clock)
    a.set_faults(drop=0.05, flip=0.10, split=8, delay_ms=30, seed=args.seed)
    b.set_faults(drop=0.05, flip=0.10, split=8, delay_ms=30, seed=args.seed + 1)
    quiet = args.json
    log = []
    t0 = clock()

    def say(text):
        if not quiet:
            print("%7.2f s  %s" % ((clock() - t0) / 1000, text))

    sent_at = {}
    latency = {}
    outcome = {}

    def listener_for(node):
        def on_event(ev):
            code = ev[0]
            if code == EV_AVAILABILITY:
                say("%-5s sees %s: %s" % (node.name, ev[2], AVAIL_NAMES[ev[3]]))
            elif code == EV_RECEIVED:
                say("%-5s <- %-5s %r" % (node.name, ev[2], bytes(ev[4]).decode()))
            elif code == EV_STATUS:
                key = (node.name, ev[2])
                if ev[3] == TRANSMITTING and key in sent_at and key not in latency:
                    latency[key] = clock() - sent_at[key][0]
                if is_final(ev[3]):
                    outcome[key] = STATUS_NAMES[ev[3]]
                    cls = sent_at.get(key, (0, 0, ""))[1]
                    if cls <= 2:
                        say("%-5s request %d (%s) %s %s" % (node.name, ev[2], PRIORITY_NAMES.get(cls, cls), STATUS_NAMES[ev[3]], ev[4]))
            log.append(ev)

        return on_event

    buoy = Node("buoy", 1, clock)
    diver = Node("diver", 2, clock)
    for n in (buoy, diver):
        n.listener = listener_for(n)
        n.names.add("buoy", 1)
        n.names.add("diver", 2)
    for n, u in ((buoy, a), (diver, b)):
        n.add_link("radio", TransparentDriver(1200), u, advert_period_ms=5000, queue_capacity=32, max_retries=3)

    def send(node, dst, text, life, prio, ack):
        rid = node.send("radio", dst, text.encode(), life, prio, ack)
        sent_at[(node.name, rid)] = (clock(), prio, text)
        return rid

    if not quiet:
        print("acomm demo: buoy (node 1) <-> diver tablet (node 2), serial radio at 1200 baud")
        print("            5 % of writes lost, 10 % with a flipped bit, split and delayed 30 ms")
        print()
    script = []
    for k in range(12):
        script.append((1500 + 2500 * k, diver, "buoy", "depth %.1f m air %d bar" % (12.5 + 0.3 * k, 180 - 2 * k), 20, 2, True))
    for k in range(15):
        script.append((8000, buoy, "diver", "chat line %02d from the surface team" % k, 120, 12, False))
    script.append((8200, diver, BROADCAST, "ALARM: low air", 30, 1, False))
    script.append((9000, buoy, "diver", "ascend now", 30, 2, True))
    script.sort(key=lambda s: s[0])
    end = 40000
    i = 0
    while clock() - t0 < end:
        now = clock() - t0
        while i < len(script) and script[i][0] <= now:
            _, node, dst, text, life, prio, ack = script[i]
            send(node, dst, text, life, prio, ack)
            if prio <= 2 or "00" in text:
                say("%-5s queues %-9s %r" % (node.name, PRIORITY_NAMES[prio], text if prio <= 2 else text + " (+14 more chat lines)"))
            i += 1
        buoy.step()
        diver.step()
        clock.advance(5)

    summary = {"seed": args.seed}
    for cls in (1, 2, 12):
        keys = [k for k, v in sent_at.items() if v[1] == cls]
        done = [k for k in keys if outcome.get(k) in ("delivered", "transmitted")]
        waits = sorted(latency[k] for k in keys if k in latency)
        summary[PRIORITY_NAMES[cls]] = {
            "requests": len(keys),
            "completed": len(done),
            "median_wait_for_air_ms": waits[len(waits) // 2] if waits else None,
        }
    for n in (buoy, diver):
        st = n.links["radio"].stats
        summary[n.name + "_link"] = {k: st[k] for k in ("tx_frames", "rx_frames", "rx_bad", "rx_duplicates", "retries", "adverts_sent")}
    if args.json:
        print(json.dumps(summary))
    else:
        print()
        print("%-10s %9s %10s %22s" % ("class", "requests", "completed", "median wait for air"))
        for cls in ("alarm", "telemetry", "chat"):
            s = summary[cls]
            w = s["median_wait_for_air_ms"]
            print("%-10s %9d %10d %19s ms" % (cls, s["requests"], s["completed"], "-" if w is None else w))
        print()
        for n in ("buoy", "diver"):
            print("%-5s link: %s" % (n, summary[n + "_link"]))
        print("damaged frames (rx_bad) were dropped by the CRC; lost ones were retried when an ack was asked for")
    return 0
