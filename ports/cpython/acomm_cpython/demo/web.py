# `acomm demo --web [HOST:]PORT [--speed X]`: the demo mission paced at X
# times real time (10 by default) with the operator console of the buoy,
# where the topside team sits, served on HOST:PORT. The console is the
# buoy's: it hears the buoy's events, shows the buoy's own traffic in its
# log, and what the operator types goes out from the buoy. What reaches the
# diver or the AUV from the console is printed on the timeline, so the
# browser test (tests/cpython/test_console_browser.py) sees it arrive.
#
# One route more than a node's console: GET /api/sim, the simulated truth
# (every node's position relative to the buoy, the simulated time, the
# USBL's error bounds), for tests and for showing how good the fixes are.
#
# In this mode the buoy's and the AUV's X150 fixes get an error (USBL_NOISE)
# so that the plan view shows a USBL's scatter; the demo without --web
# keeps its exact fixes, and its figures do not change.

import signal
import time

from acomm.catalog import seaware
from acomm.errors import AcommError

from .places import ADDR, BUOY

USBL_NOISE = (0.3, 1.0)  # range m, bearing degrees: the largest error, uniform


def _truth(m):
    ch = m.channel
    o = ch.position(ADDR[BUOY])
    out = {}
    for name, addr in ADDR.items():
        p = ch.position(addr)
        out[name] = [round(p[0] - o[0], 2), round(p[1] - o[1], 2), round(p[2], 2)]
    return out


class _Log:
    # the console's command log (acomm_web.host.WebHost out) on the timeline
    def __init__(self, m):
        self.m = m

    def emit(self, d):
        a = d["answer"]
        self.m.say(self.m.world.now(), "console", "%s: %s -> %d %s" % (d["by"], d["command"], d["code"],
                                                                      a.get("error") or a))


class WebDemo:
    """The console of the mission's buoy, served while the mission runs paced."""

    def __init__(self, args, m):
        from acomm.apps.console import ConsoleState
        from acomm_web.host import WebHost, parse_web, read_password, tee

        host, port = parse_web(args.web)
        password = read_password(args.web_password_file) if args.web_password_file else None
        self.m = m
        self.speed = args.speed or 10.0
        buoy = m.nodes[BUOY].node
        self.state = state = ConsoleState(buoy)
        tee(buoy, state)

        def watch(name, rid, dst, data, cls, now):
            if name == BUOY:
                state.sent(now, "acoustic", rid, dst, cls, state.decode(data)[1])

        m.traffic.watch = watch

        def other(now, me, src, data):
            # what the buoy sent that the mission did not: the console's
            # chat lines and commands (the CADDY cycle's own messages and
            # empty interrogations are not shown)
            if src != BUOY or not data:
                return
            try:  # a Seaware packet has its own CRC: tried first
                cls, text = "seaware", seaware.decode(bytes(data))[1].name
            except AcommError:
                cls, text = state.decode(data)
                if cls not in ("chat", "command"):
                    return
            m.say(now, "console", "%s <- %s %s %r (from the console)" % (me, src, cls, text))

        m.on_other = other
        self.web = WebHost(state, host, port, password, _Log(m), extra_routes=self._routes)
        self.stop = []

    def _routes(self, app, wc):
        m = self.m

        @app.get("/api/sim")
        async def sim(request):
            with wc.lock:
                return {"time_s": m.world.now() / 1000, "speed": self.speed, "truth": _truth(m),
                        "usbl_noise": {"range_m": USBL_NOISE[0], "bearing_deg": USBL_NOISE[1]}}

    def run(self):
        """Serves and runs the mission paced; False when stopped early (Ctrl-C, SIGTERM)."""
        from acomm_web.host import paced

        self.web.start()
        print("console: %s (the buoy's; %g x real time)" % (self.web.url, self.speed), flush=True)
        self._old = signal.signal(signal.SIGTERM, lambda *a: self.stop.append(1))
        try:
            self.m.run(lambda world, end: paced(world, end, self.speed, self.web.lock, self.state.poll,
                                                stop=lambda: bool(self.stop)))
        except KeyboardInterrupt:
            self.stop.append(1)
        return not self.stop

    def linger(self):
        """Keeps serving the mission's last state until Ctrl-C or SIGTERM."""
        print("console: the mission is over; still serving %s (Ctrl-C to stop)" % self.web.url, flush=True)
        try:
            while not self.stop:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass

    def close(self):
        signal.signal(signal.SIGTERM, self._old)
        self.web.stop()
