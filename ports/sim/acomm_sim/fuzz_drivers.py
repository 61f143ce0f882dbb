# Fuzz targets for every modem driver, fed through its byte stream
# (acomm_sim.fuzz has the engine). No hand-written corpus: each target runs
# the driver against its emulator in a World once and records what the
# modem wrote to the host, start-up and a delivery each way included. That
# session is the corpus, and the timeline a case replays.
#
# A case (two oracles):
#  * replay: a fresh driver gets the recorded session in time order with
#    the mutated input fed at a random point (and, now and then, more
#    mutated chunks); only acomm errors may escape feed/poll/events.
#  * probe (1 case in PROBE_EVERY): a fresh World where the buoy's driver
#    and its real modem are up; mutated inputs are injected into the line
#    as noise, then a packet must be delivered each way within PROBE_MS of
#    virtual time: the driver resynchronised and still accepts valid input.
#    The probe is what costs (a World per probe), hence its rate.

from acomm.events import DELIVERED, EV_RECEIVED, EV_STATUS, is_final

from .fuzz_base import Failure, mutate
from .world import MODEMS, World

PROBE_EVERY = 64
PROBE_MS = 600000  # ten minutes of virtual time: link retries and a restart fit

_SAT_DRIVER = {"retry_first_ms": 5000, "retry_max_ms": 20000, "give_up_ms": 600000, "mo_mtu": 270}
_SAT_LINK = {"advert_period_ms": 3600000, "ack_timeout_ms": 60000, "medium": "satellite"}
_GSM_DRIVER = {"retry_ms": 1000, "csq_retry_ms": 5000, "list_period_ms": 60000}
_GSM_LINK = {"advert_period_ms": 3600000, "ack_timeout_ms": 60000}
_AC_LINK = {"advert_period_ms": 600000}

# target name, modem of world.MODEMS, link name, driver opts, emulator opts, link opts
SPECS = (
    ("drv.seatrac", "seatrac", "acoustic", None, None, _AC_LINK),
    ("drv.evologics", "evologics", "acoustic", None, None, _AC_LINK),
    ("drv.micromodem", "micromodem", "acoustic", None, None, _AC_LINK),
    ("drv.benthos", "benthos", "acoustic", None, None, _AC_LINK),
    ("drv.transparent", "bpsk", "acoustic", None, None, _AC_LINK),
    ("drv.iridium", "iridium", "satellite", _SAT_DRIVER, {"session_ms": 2000}, _SAT_LINK),
    ("drv.sms", "gsm", "gsm", _GSM_DRIVER, None, _GSM_LINK),
)


def two_nodes(spec, tap=None):
    # Two nodes on one modem type, both drivers up. tap(now, bytes) sees
    # what the buoy's modem writes to its host.
    name, modem, link, dopts, eopts, lopts = spec
    w = World(seed=5)
    a = w.add("buoy", 1, modem, position=(0.0, 0.0, 1.0), link=link, driver_opts=dopts, emu_opts=eopts,
              link_opts=lopts)
    if tap is not None:
        dev = a.modem_end
        write = dev.write

        def tapped(buf):
            tap(w.now(), bytes(buf))
            return write(buf)

        dev.write = tapped
    b = w.add("diver", 2, modem, position=(120.0, 0.0, 10.0), link=link, driver_opts=dopts, emu_opts=eopts,
              link_opts=lopts)
    if not w.run(60000, until=lambda: a.driver.ready(w.now()) and b.driver.ready(w.now())):
        raise RuntimeError("%s: drivers not up against the emulators" % name)
    return w, a, b


def exchange(w, a, b, link, tag, limit_ms):
    # one acknowledged packet each way, one after the other (a half-duplex
    # medium loses two at once); -> True when both were delivered
    def final(sn, rid):
        s = [e[3] for e in sn.events if e[0] == EV_STATUS and e[2] == rid]
        return s[-1] if s and is_final(s[-1]) else None

    def got(sn, data):
        return any(e[0] == EV_RECEIVED and bytes(e[4]) == data for e in sn.events)

    for src, dst, name in ((a, b, "diver"), (b, a, "buoy")):
        data = b"fuzz " + name.encode() + b" " + tag
        rid = src.node.send(link, name, data, 3600, 2, True)
        w.run(limit_ms, until=lambda: final(src, rid) is not None and got(dst, data))
        if final(src, rid) != DELIVERED or not got(dst, data):
            return False
    return True


class DriverTarget:
    def __init__(self, spec):
        self.spec = spec
        self.name = spec[0]
        timeline = []
        w, a, b = two_nodes(spec, lambda t, d: timeline.append((t, d)))
        if not exchange(w, a, b, spec[2], b"corpus", PROBE_MS):
            raise RuntimeError("%s: no delivery against the emulators" % self.name)
        self.timeline = timeline
        self.corpus = [d for _, d in timeline if d]
        self.end = w.now()

    def _driver(self):
        _, modem, _, dopts, _, _ = self.spec
        return MODEMS[modem][0](1, dict(dopts or {}))

    def run(self, data, rng):
        if rng.below(PROBE_EVERY) == 0:
            return self.probe(data, rng)
        d = self._driver()
        tl = self.timeline
        at = rng.below(len(tl) + 1)
        extra = rng.below(4)
        for i in range(len(tl) + 1):
            t = tl[i][0] if i < len(tl) else self.end
            if i == at:
                d.feed(t, data)
            elif extra and rng.chance(0.1):
                extra -= 1
                d.feed(t, mutate(rng, self.corpus, 512))
            if i < len(tl):
                d.feed(t, tl[i][1])
            d.poll(t)
            d.take_output()
            d.take_events()
        d.poll(self.end + 120000)  # every timer the garbage may have started
        d.take_events()

    def probe(self, data, rng):
        w, a, b = two_nodes(self.spec)
        # the corpus holds whole valid packets (ids 1 each way): a warm-up
        # exchange moves the probe's ids past them, or a replayed copy
        # would make the probe a duplicate that is rightly suppressed
        if not exchange(w, a, b, self.spec[2], b"warm-up", PROBE_MS):
            raise RuntimeError("%s: no delivery before the garbage" % self.name)
        host = a.host_end
        for k in range(1 + rng.below(4)):
            w.run(rng.below(3000))
            host.inject(data if k == 0 else mutate(rng, self.corpus, 512))
        w.run(1000)
        if not exchange(w, a, b, self.spec[2], b"probe", PROBE_MS):
            raise Failure("%s: no delivery both ways within %d s after the garbage" % (self.name, PROBE_MS // 1000))


def targets():
    return [DriverTarget(s) for s in SPECS]
