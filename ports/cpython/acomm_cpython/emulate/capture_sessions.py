# The sessions behind the shipped capture fixtures (tests/cpython/fixtures/
# captures/<modem>.jsonl): acomm's driver for node 1 against its emulated
# modem, on virtual time in 10 ms steps, while a second modem and driver
# (node 2) share the water, the gateway or the SMS centre. The exchanges are
# the ones of the device's conformance table (docs/drivers-*.md): start-up,
# one frame sent 1 -> 2 (acknowledged where the modem can), one frame back
# 2 -> 1 (Iridium: an MT message waiting at the gateway). Node 1's serial
# line is written as a capture (acomm_cpython.emulate.capture). Deterministic: the
# same code makes the same file, which a test checks.
#
#   python tools/make_captures.py [modem ...]    rewrites the fixtures

from .capture import TO_DEVICE, TO_HOST, CaptureWriter

MODEMS = ("seatrac", "evologics", "micromodem", "benthos", "iridium", "gsm")
STEP_MS = 10
# the Micro-Modem at rate 0: its cycle-init mini-packet is in the capture
DRIVER_OPTS = {"micromodem": {"rate": 0}}
OUT = b"hello from 1"
BACK = b"reply from 2"


def run_session(modem, writer, max_ms=300000):
    """Run the session, recording node 1's line; node 1's [(t, event)], its
    sends as ("send", handle, addr), as acomm_cpython.emulate.replay gives them."""
    from acomm_sim.medium import Medium
    from acomm_sim.world import MODEMS as FACTORIES

    make_driver, make_emu = FACTORIES[modem]
    medium = Medium(default_distance=500.0, seed=1)
    emus = [make_emu(medium, a, 0, {}) for a in (1, 2)]
    drivers = [make_driver(a, dict(DRIVER_OPTS.get(modem, {}))) for a in (1, 2)]
    if modem == "iridium":
        emus[0].queue_incoming(0, BACK)  # node 1's mailbox at the gateway
    events = ([], [])
    handles = [None, None]
    done_at = None
    from acomm.drivers.caps import CAP_RELIABLE

    ack = bool(drivers[0].caps.flags & CAP_RELIABLE)  # acknowledged where the modem can
    t = 0
    while t <= max_ms:
        for k in (0, 1):
            emu, drv = emus[k], drivers[k]
            w = drv.take_output()
            if w:
                if k == 0:
                    writer.record(t, TO_DEVICE, w)
                emu.feed(t, w)
            emu.poll(t)
            medium.poll(t)
            out = emu.take_output()
            if out:
                if k == 0:
                    writer.record(t, TO_HOST, out)
                drv.feed(t, out)
            drv.poll(t)
            events[k].extend((t, e) for e in drv.take_events())
        if handles[0] is None and drivers[0].ready(t) and drivers[1].ready(t):
            writer.send(t, 2, OUT, ack)
            handles[0] = drivers[0].send(t, 2, OUT, ack)
            events[0].append((t, ("send", handles[0], 2)))
        elif handles[0] is not None and handles[1] is None and modem != "iridium" and _final(events[0], handles[0], ack) \
                and drivers[1].ready(t):
            handles[1] = drivers[1].send(t, 1, BACK, False)
        if done_at is None and _final(events[0], handles[0], ack) and _heard(events[0], BACK):
            done_at = t
        if done_at is not None and t - done_at >= 2000:
            break
        t += STEP_MS
    return events[0]


def _final(events, h, ack):
    # the driver's last word on send h
    from acomm.events import EV_DELIVERED, EV_TX_DONE, EV_TX_FAILED

    if h is None:
        return False
    ends = (EV_DELIVERED, EV_TX_FAILED) if ack else (EV_TX_DONE, EV_TX_FAILED)
    for _, e in events:
        if e[0] in ends and e[1] == h:
            return True
    return False


def _heard(events, data):
    from acomm.events import EV_RX

    return any(e[0] == EV_RX and bytes(e[-1]) == data for _, e in events)


def write_fixture(modem, path):
    with open(path, "w") as f:
        w = CaptureWriter(f, modem)
        return run_session(modem, w)
