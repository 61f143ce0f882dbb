# `acomm replay FILE --driver NAME`: feed the modem -> host bytes of a
# capture (acomm_cpython.emulate.capture) through one of acomm's drivers at their
# recorded times and print the events the driver yields, one per line:
#
#   12040 EV_DRIVER_UP
#   31210 EV_RX src=2 dst=1 data=68656c6c6f ('hello')
#
# A send the capture records (captures of acomm's own sessions have them)
# is made again at its time, so its statuses show too ("send" lines).
# The driver is polled every step_ms between the records, as a running host
# polls it, so its timers (command timeouts, retries) fire where they did.
# What the driver writes is dropped (--writes prints it, as "> hex"): the
# replay shows how the driver reads what the modem said. A capture made by
# acomm's own driver replays to the same events (the driver is
# deterministic); one from other host software shows how acomm's driver
# would have read that modem's bytes. A damaged file: one line naming the
# file and the line, exit 2.

from .capture import SEND, TO_HOST

# driver names: those of acomm_sim.world.MODEMS (seatrac, evologics,
# micromodem, benthos, iridium, gsm, bpsk, fhss)


def make_driver(name, address, options):
    from acomm_sim.world import MODEMS

    if name not in MODEMS:
        raise ValueError("unknown driver %r (one of %s)" % (name, ", ".join(sorted(MODEMS))))
    return MODEMS[name][0](address, dict(options))


def event_names():
    import acomm.events as ev

    return dict((getattr(ev, k), k) for k in dir(ev) if k.startswith("EV_"))


def replay(records, driver, step_ms=10, tail_ms=0, writes=None):
    """Run the driver over the capture's records from t = 0; [(t_ms, event)]
    in order, where a send the capture records gives ("send", handle, addr)
    or ("send refused", reason). writes(t, bytes), when given, sees what
    the driver wrote."""
    from acomm.errors import AcommError

    out = []

    def drain(now):
        out.extend((now, e) for e in driver.take_events())
        w = driver.take_output()
        if w and writes is not None:
            writes(now, w)

    end_at = (records[-1][0] if records else 0) + tail_ms
    t = 0
    i = 0
    while True:
        while i < len(records) and records[i][0] <= t:
            _, to, data = records[i]
            i += 1
            if to == TO_HOST:
                driver.feed(t, data)
            elif to == SEND:
                driver.poll(t)  # a host polls, then its application asks
                drain(t)
                addr, payload, ack = data
                try:
                    out.append((t, ("send", driver.send(t, addr, payload, ack), addr)))
                except AcommError as e:
                    out.append((t, ("send refused", str(e))))
            drain(t)
        driver.poll(t)
        drain(t)
        if i >= len(records) and t >= end_at:
            return out
        # the next poll, or the next record if it comes sooner
        t_next = t + step_ms
        if i < len(records) and records[i][0] < t_next:
            t_next = records[i][0]
        t = t_next


def describe(ev, names):
    # one event as text: its name, then its fields
    parts = [ev[0] if isinstance(ev[0], str) else names.get(ev[0], str(ev[0]))]
    for x in ev[1:]:
        if isinstance(x, (bytes, bytearray)):
            b = bytes(x)
            parts.append("%s (%r)" % (b.hex(), b))
        else:
            parts.append(repr(x))
    return " ".join(parts)
