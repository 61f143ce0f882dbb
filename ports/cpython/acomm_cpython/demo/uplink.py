# The buoy's satellite uplink in the demo mission, on the World's virtual
# clock (issue 38, point 5): the buoy's real Iridium driver on an emulated
# 9603 (acomm_sim.iridium), the simulated gateway (acomm_sim.iridium_net),
# and a shore node with no modem, whose ShoreDriver link
# (acomm_cpython.shore.driver) takes each MO message as DirectIP bytes and
# gives its frames back as MT messages by DirectIP:
#
#   buoy --SBD session--> gateway --DirectIP MO--> shore node
#   buoy <--SBDIX(A) after the ring alert-- gateway MT queue <--DirectIP MT-- shore node
#
# The bytes are the protocol's own: the gateway side writes them with the
# emulator's gateway (emulate.directipgw: encode_mo, queue, confirm) and the
# shore side reads them with its sans-IO Reader and takes them as its socket
# port does (shore.directip_port: take_mo, mt_refusal). Only TCP is left
# out: a socket waits in real time and the World runs about a thousand
# times faster, so each "connection" is one message handed across in
# memory, DELIVERY_MS after the session (a model choice: the gateway's
# delivery delay is not in our references). The real sockets are tested in
# tests/cpython/test_shore_*.py and `acomm bench surface`.
#
# The plan's part: the buoy relays the diver's alarm to shore (acknowledged)
# and the shore answers with a command, which waits in the gateway's MT
# queue until the buoy's next session (the gateway's ring alert brings it).

from acomm.compat import ticks_add, ticks_diff
from acomm.events import AVAILABLE, DELIVERED, EV_AVAILABILITY, EV_RECEIVED, EV_STATUS, STATUS_NAMES, is_final
from acomm.link.names import NameTable
from acomm.node import Node

from ..emulate.directipgw import DirectIpGateway
from ..shore import directip as dip
from ..shore.directip_port import mt_refusal, take_mo
from ..shore.driver import ShoreDriver
from ..shore.seen import Replays
from ..shore.spec import LINK_OPTIONS
from .places import ADDR, BUOY

SHORE = "shore"
SHORE_ID = 4
SAT = "satellite"
DELIVERY_MS = 2000  # from the session's end to the shore's DirectIP connection
EPOCH_S = 1780304400  # the mission starts 2026-06-01 09:00 UTC: DirectIP's time of session repeats
TICK_MS = 1000  # how often the shore node is stepped
COMMAND = b"shore: abort the dive, recover the diver"
# the buoy's driver as on the boards (docs/drivers-iridium.md), sessions of 8 s
DRIVER = {"retry_first_ms": 20000, "retry_max_ms": 160000, "give_up_ms": 600000, "mo_mtu": 270}


class VirtualDirectIp:
    """The gateway's DirectIP service and a shore's DirectIP port joined without sockets: a frame
    port (pump(now)) for a ShoreDriver. say(now, tag, text) is told each message."""

    def __init__(self, net, driver, say, epoch_s=EPOCH_S, delay_ms=DELIVERY_MS):
        self.gw = DirectIpGateway(net, epoch_s=epoch_s)  # no listener, no outbox: no thread
        self.driver = driver
        self.say = say
        self.delay_ms = delay_ms
        self.seen = Replays(4096)
        self.refused = {}  # reason -> count, as the socket port counts them
        self.stats = {"mo_taken": 0, "mo_again": 0, "mt_queued": 0, "mt_refused": 0}
        self.mo = []  # (ticks delivered, MOMSN, DirectIP bytes, confirmation byte)
        self.mt = []  # (ticks, client id, DirectIP bytes, MT confirmation status)
        self._wire = []  # [due ticks, MOMSN, DirectIP bytes], oldest first
        self._cid = 0
        net.shores.append(self._session)

    def _session(self, now, imei, serial, momsn, mtmsn, data):
        # the gateway's hook, as a session with an MO message ends
        self._wire.append([ticks_add(now, self.delay_ms), momsn, self.gw.encode_mo(now, imei, momsn, mtmsn, data)])

    def next_due(self):
        """When the next MO message reaches the shore (ticks), or None."""
        return self._wire[0][0] if self._wire else None

    def pump(self, now):
        while self._wire and ticks_diff(now, self._wire[0][0]) >= 0:
            _, momsn, msg = self._wire.pop(0)
            self._mo_connection(now, momsn, msg)
        for handle, imei, frame in self.driver.take_mt():
            self._mt_connection(now, handle, imei, frame)

    def _mo_connection(self, now, momsn, msg):
        # the shore reads one message and answers; the gateway reads the MO confirmation
        try:
            ies = dip.Reader(dip.MO_IES).feed(msg)
            why = "truncated" if ies is None else take_mo(self.driver, self.seen, self.stats, now, dip.decode_mo(ies))
        except dip.DirectIpError as e:
            why = e.reason
        if why is not None:
            self.refused[why] = self.refused.get(why, 0) + 1
        conf = dip.Reader((dip.MO_CONFIRMATION,), 64).feed(dip.encode_mo_confirmation(why is None))
        taken = conf[dip.MO_CONFIRMATION][0]
        self.mo.append((now, momsn, msg, taken))
        self.say(now, "directip", "gateway -> shore: MO MOMSN %d by DirectIP (%d B: MO header, location, "
                 "payload), MO confirmation %d" % (momsn, len(msg), taken))

    def _mt_connection(self, now, handle, imei, frame):
        # the shore writes one MT message; the gateway queues it and confirms; the shore reads that
        self._cid = (self._cid + 1) & 0xFFFFFFFF
        msg = dip.encode_mt(self._cid, imei, frame)
        try:
            mt = dip.decode_mt(dip.Reader(dip.MT_IES, dip.MT_MAX + 64).feed(msg))
            status = self.gw.queue(now, mt)
        except dip.DirectIpError:
            mt, status = None, -7
        ies = dip.Reader((dip.MT_CONFIRMATION,), 64).feed(self.gw.confirm(mt, status))
        why = mt_refusal(self._cid, ies)
        self.stats["mt_refused" if why else "mt_queued"] += 1
        self.mt.append((now, self._cid, msg, status))
        self.say(now, "directip", "shore -> gateway: MT message %d by DirectIP (%d B), %s"
                 % (self._cid, len(msg), why or "queued at the gateway, place %d" % status))
        self.driver.sent(now, handle, why)

    def close(self, now=0):
        pass


class Uplink:
    """The buoy's Iridium link and the shore node, joined to mission m's World (a task of it)."""

    def __init__(self, m):
        self.m = m
        w = m.world
        self.buoy = w.nodes[BUOY]
        w.add_link(BUOY, SAT, "iridium", driver_opts=DRIVER, link_opts=LINK_OPTIONS)
        self.modem = self.buoy.extra[-1][2]  # the emulated 9603 (World.add_link keeps it there)
        self.driver = ShoreDriver("directip", imei=self.modem.imei)
        self.port = VirtualDirectIp(self.modem.net, self.driver, m.say)
        self.node = Node(SHORE, SHORE_ID, w.clock, names=NameTable(8), listener=self._shore_event)
        self.node.add_link(SAT, self.driver, self.port, **LINK_OPTIONS)
        self.node.names.add(BUOY, ADDR[BUOY])
        self.buoy.node.names.add(SHORE, SHORE_ID)
        self.heard = {}  # who -> ms each end first saw the other available
        self.report = None  # [rid, sent, at shore, acknowledged] in ms
        self.command = None  # [rid, sent, at the buoy, acknowledged, the session's command]
        w.add_task(self)

    def poll(self, now):
        """World task: one step of the shore node -> when it wants the next."""
        self.node.step(now)
        due = self.port.next_due()
        wake = ticks_add(now, TICK_MS)
        return due if due is not None and ticks_diff(due, wake) < 0 else wake

    # -- the buoy's side -----------------------------------------------------------------------
    def relay(self, now, text):
        """The buoy sends text to shore over Iridium (once, acknowledged, ahead of anything else)."""
        if self.report is not None:
            return
        rid = self.buoy.node.send(SAT, SHORE, text, 3600, 1, True, now=now)
        self.report = [rid, now, None, None]
        self.m.say(now, "uplink", "buoy -> shore %r over Iridium SBD (acknowledged): an MO message in the "
                   "buoy's next session" % text.decode())

    def buoy_event(self, now, ev):
        """An event of the buoy's satellite link (the mission's listener hands them here)."""
        code = ev[0]
        if code == EV_RECEIVED and ev[2] == SHORE and self.command is not None and self.command[2] is None:
            self.command[2] = now
            # the session that brought it: AT+SBDIXA answers the gateway's ring alert, AT+SBDIX is a
            # mailbox check (or one that sent an MO message)
            cmd = "AT" + self.modem.sessions[-1][1].decode() if self.modem.sessions else "?"
            self.command[4] = cmd
            self.m.say(now, "uplink", "buoy <- shore %r after %.1f s: the MT message came in its %s session%s"
                       % (ev[4].decode(), (now - self.command[1]) / 1000, cmd,
                          " (the answer to the gateway's ring alert)" if cmd.endswith("SBDIXA") else ""))
        elif code == EV_STATUS:
            self._final(now, ev, self.report, "uplink", BUOY, SHORE, "alarm report", "back as an MT message")
        elif code == EV_AVAILABILITY:
            self._heard(now, BUOY, ev)

    # -- the shore's side ----------------------------------------------------------------------
    def _shore_event(self, ev):
        now = self.m.world.now()
        code = ev[0]
        if code == EV_RECEIVED and ev[2] == BUOY and self.report is not None and self.report[2] is None:
            self.report[2] = now
            self.m.say(now, "shore", "shore <- buoy %r after %.1f s (SBD session, gateway, DirectIP)"
                       % (ev[4].decode(), (now - self.report[1]) / 1000))
            rid = self.node.send(SAT, BUOY, COMMAND, 3600, 1, True, now=now)
            self.command = [rid, now, None, None, None]
            self.m.say(now, "shore", "shore -> buoy %r as an MT message (acknowledged)" % COMMAND.decode())
        elif code == EV_STATUS:
            self._final(now, ev, self.command, "shore", SHORE, "the " + BUOY, "command", "by DirectIP")
        elif code == EV_AVAILABILITY:
            self._heard(now, SHORE, ev)

    def _final(self, now, ev, req, tag, me, other, what, way):
        # me's request req ([rid, sent, arrived, acknowledged, ...]) ends with EV_STATUS ev
        if req is None or ev[2] != req[0] or not is_final(ev[3]):
            return
        if ev[3] == DELIVERED:
            req[3] = now
            self.m.say(now, tag, "%s: %s acknowledged the %s after %.1f s (its ACK came %s)"
                       % (me, other, what, (now - req[1]) / 1000, way))
        else:
            self.m.say(now, tag, "%s: the %s %s %s" % (me, what, STATUS_NAMES[ev[3]], ev[4]))

    def _heard(self, now, me, ev):
        if ev[3] == AVAILABLE and me not in self.heard:
            self.heard[me] = now
            self.m.say(now, "uplink", "%s hears %s over Iridium" % (me, ev[2]))

    def summary(self):
        """The uplink's figures for the demo's summary (seconds of simulated time)."""
        def s(t0, t1):
            return None if t0 is None or t1 is None else round((t1 - t0) / 1000, 3)

        r = self.report or [None] * 4
        c = self.command or [None] * 5
        return {
            "mo_by_directip": len(self.port.mo),
            "mo_momsn": [x[1] for x in self.port.mo],
            "mt_by_directip": len(self.port.mt),
            "mt_statuses": [x[3] for x in self.port.mt],
            "report_to_shore_s": s(r[1], r[2]),
            "report_acked_s": s(r[1], r[3]),
            "command_to_buoy_s": s(c[1], c[2]),
            "command_session": c[4],
            "command_acked_s": s(c[1], c[3]),
            "refused": dict(self.port.refused),
        }
