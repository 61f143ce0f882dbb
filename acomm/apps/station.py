# What a board's node does besides carrying packets: the application side
# of a buoy or a diver's tablet, so that boards/ carry only configuration.
#
#   st = Station(node, transport, report_to="shore", report_period_s=600,
#                make_report=lambda now: b"...")
#   st.alarm(now, "low_air")          # urgent, CADDY ALARM
#   st.chat(now, "all ok")            # CADDY CHAT
#   st.command(now, "auv", "stop")    # CADDY COMMAND
#   st.poll(now)                      # periodic report when due
#
# Packets that arrive are decoded with the CADDY catalog when they parse as
# CADDY messages (positions, commands, alarms, chat) and kept in a bounded
# inbox, newest last, as (source, message name, values); anything else is
# kept as (source, None, bytes). A relay (the buoy) needs none of this: the
# transport stores and forwards on its own. Counters say what was sent,
# received, dropped from the inbox and refused by the transport.

from ..catalog import caddy
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError

# acomm.events' code and fields, as private constants (inlined: no RAM)
_EV_PACKET = const(27)
_PACKET_SRC = const(1)
_PACKET_DATA = const(3)

_INBOX = const(16)
_ALARM_PRIORITY = const(1)
_COMMAND_PRIORITY = const(3)
_CHAT_PRIORITY = const(8)
_REPORT_PRIORITY = const(10)


class Station:
    def __init__(self, node, transport, report_to=None, report_period_s=0, make_report=None, lifespan_s=3600,
                 alarm_to=None, inbox=_INBOX):
        self.node = node
        self.transport = transport
        self.report_to = report_to
        self.alarm_to = alarm_to or report_to
        self.period_ms = int(report_period_s * 1000)
        self.make_report = make_report
        self.lifespan_s = lifespan_s
        self.inbox_capacity = inbox
        self.inbox = []
        self._due = None
        self.stats = {"reports": 0, "alarms": 0, "chats": 0, "commands": 0, "received": 0, "inbox_dropped": 0,
                      "refused": 0}
        node.listen(self._on_event)

    # -- sending ----------------------------------------------------------------
    def _send(self, now, dst, data, prio, what):
        try:
            pid = self.transport.send(now, dst, data, self.lifespan_s, prio)
        except AcommError:
            # unknown destination, too big: the caller's mistake is counted,
            # the node goes on
            self.stats["refused"] += 1
            return None
        self.stats[what] += 1
        return pid

    def alarm(self, now, name):
        data = caddy.CATALOG.pack([(caddy.ALARM, {"alarm": name})])
        return self._send(now, self.alarm_to, data, _ALARM_PRIORITY, "alarms")

    def chat(self, now, text, dst=None):
        data = caddy.CATALOG.pack([(caddy.CHAT, {"text": text})])
        return self._send(now, dst or self.report_to, data, _CHAT_PRIORITY, "chats")

    def command(self, now, dst, name):
        data = caddy.CATALOG.pack([(caddy.COMMAND, {"command": name})])
        return self._send(now, dst, data, _COMMAND_PRIORITY, "commands")

    def poll(self, now):
        if not self.period_ms or self.make_report is None or self.report_to is None:
            return
        if self._due is None:
            self._due = ticks_add(now, self.period_ms)
            return
        if ticks_diff(now, self._due) < 0:
            return
        self._due = ticks_add(now, self.period_ms)
        data = self.make_report(now)
        if data:
            self._send(now, self.report_to, data, _REPORT_PRIORITY, "reports")

    # -- receiving --------------------------------------------------------------
    def _on_event(self, ev):
        if ev[0] == _EV_PACKET:
            self.stats["received"] += 1
            self._keep(ev[_PACKET_SRC], ev[_PACKET_DATA])

    def _keep(self, src, data):
        try:
            items = [(src, m.name, v) for m, v in caddy.CATALOG.unpack(data)]
        except DecodeError:
            items = []
        if not items:
            items = [(src, None, bytes(data))]
        for it in items:
            if len(self.inbox) >= self.inbox_capacity:
                self.inbox.pop(0)
                self.stats["inbox_dropped"] += 1
            self.inbox.append(it)

    def take_inbox(self):
        """The messages received since the last call, oldest first: [(source, kind, values)]."""
        got = self.inbox
        self.inbox = []
        return got


def diver_report(sensors):
    # make_report for a diver's tablet: sensors() -> dict of DIVER_STATUS
    # values (heart_rate, breathing_rate, body_temp; any may be missing)
    def make(now):
        v = {"heart_rate": None, "breathing_rate": None, "body_temp": None}
        v.update(sensors())
        return caddy.CATALOG.pack([(caddy.DIVER_STATUS, v)])

    return make
