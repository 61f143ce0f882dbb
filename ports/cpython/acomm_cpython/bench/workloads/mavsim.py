# `acomm bridge mavlink`'s two sides in the simulated ocean (acomm_sim.World),
# for `acomm bench mavlink`: the real VehicleSide and TopsideSide, their
# MAVLink through real pymavlink bytes (MavEndpoint encode and feed), two
# real nodes with the network key and the bridge's guard, real drivers on
# emulated modems, on the simulated clock. A scripted GCS feeds the topside
# MANUAL_CONTROL at 50 Hz from a stick schedule; a scripted autopilot reads
# every MANUAL_CONTROL the vehicle side sends and answers its commands.
#
# What the bridge process adds beyond this (asyncio, sockets) is measured
# by the same bench over `acomm emulate seatrac` (mavlink_workload).

from acomm import events as E
from acomm.apps.policy import commands
from acomm.catalog import rovcontrol as R
from acomm.compat import ticks_diff
from acomm.errors import AcommError
from acomm.frame.auth import Auth
from acomm.link.guard import Guard

from ...bridges.mavtopside import TopsideSide
from ...bridges.mavvehicle import VehicleSide
from ...bridges.mavwire import AUTOPILOT_COMPONENT, GCS_COMPONENT, GCS_SYSID, MAV, MavEndpoint
from ...bridges.mavbridge import SENDING, UPLINK, kind

KEY = bytes(range(16))
GCS_PERIOD_MS = 20  # a 50 Hz joystick


class SimBridges:
    """Both bridges on nodes `top` and `veh` (acomm_sim SimNodes) of world `w`; stick(now) -> the GCS's
    (x, y, z, r, s, t) at that time. Records: manual (t, (x, y, z, r, s, t)) at the autopilot,
    received (t) of acoustic packets at the vehicle, uplink (packet, airtime ms) of every packet the
    topside's modem put on the water (frames with header and authentication trailer)."""

    def __init__(self, w, top, veh, stick, keepalive_ms=2000, timeout_ms=5000, stick_gap_ms=500,
                 reply_ms=1000):
        self.w = w
        self.top, self.veh = top, veh
        self.stick = stick
        guard = Guard(commands().checks + (R.guard_check,))
        for sn in (top, veh):
            sn.node.set_auth(Auth(KEY), guard)
        now = w.now()
        self.gcs_end = MavEndpoint(GCS_SYSID, GCS_COMPONENT)  # the scripted GCS
        self.top_end = MavEndpoint(1, AUTOPILOT_COMPONENT)
        self.veh_end = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
        self.ap_end = MavEndpoint(1, AUTOPILOT_COMPONENT)  # the scripted autopilot
        self.topside = TopsideSide(self.top_end.mav, now, keepalive_ms=keepalive_ms, stick_gap_ms=stick_gap_ms,
                                    reply_ms=reply_ms, command_poll_ms=2 * reply_ms)
        self.vehicle = VehicleSide(self.veh_end.mav, now, timeout_ms=timeout_ms)
        self.manual = []
        self.received = []
        self.uplink = []
        transmit = w.channel.transmit

        def tap(now, src, packet, airtime_ms):
            if src == top.address:
                self.uplink.append((packet, airtime_ms))
            return transmit(now, src, packet, airtime_ms)

        w.channel.transmit = tap
        self.armed = False
        self._stick_rid = None
        self._names = {}  # request id -> message name, of the topside's sends
        self._gcs_at = None
        self._beat_at = None
        top.node.listen(self._top_event)
        veh.node.listen(self._veh_event)

    # -- the scripted peers -------------------------------------------------------------------
    def _gcs(self, now):
        if self._gcs_at is not None and ticks_diff(now, self._gcs_at) < GCS_PERIOD_MS:
            return
        self._gcs_at = now
        x, y, z, r, s, t = self.stick(now)
        m = self.gcs_end.mav.manual_control_encode(1, x, y, z, r, 0, enabled_extensions=3, s=s, t=t)
        self._to(self.topside, self.top_end, now, [m], self.gcs_end)

    def command(self, now, command, p1, p2=0.0):
        m = self.gcs_end.mav.command_long_encode(1, 1, command, 0, p1, p2, 0, 0, 0, 0, 0)
        self._to(self.topside, self.top_end, now, [m], self.gcs_end)

    def _autopilot(self, now, msgs):
        out = []
        if self._beat_at is None or ticks_diff(now, self._beat_at) >= 1000:
            self._beat_at = now
            base = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (MAV.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            out.append(self.ap_end.mav.heartbeat_encode(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                                        MAV.SUB_MODE_MANUAL, MAV.MAV_STATE_ACTIVE))
        for m in msgs:
            t = m.get_type()
            if t == "MANUAL_CONTROL":
                self.manual.append((now, (m.x, m.y, m.z, m.r, m.s, m.t)))
            elif t == "COMMAND_LONG" and m.command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
                self.armed = m.param1 >= 0.5
                out.append(self.ap_end.mav.command_ack_encode(m.command, MAV.MAV_RESULT_ACCEPTED))
        if out:
            self._to(self.vehicle, self.veh_end, now, out, self.ap_end)

    @staticmethod
    def _to(side, end, now, msgs, sender):
        # through the bytes, as over a socket
        data = b"".join(sender.encode(m) for m in msgs)
        for m in end.feed(data):
            side.mavlink_in(now, m)

    # -- the nodes ------------------------------------------------------------------------------
    def _top_event(self, ev):
        if ev[0] == E.EV_STATUS and E.is_final(ev[3]):
            name = self._names.pop(ev[2], None)
            if name is not None:
                self.topside.transmitted(self.w.now(), name)
            if ev[2] == self._stick_rid:
                self._stick_rid = None
        elif ev[0] == E.EV_RECEIVED and ev[2] == "vehicle":
            self._acoustic(self.topside, ev)

    def _veh_event(self, ev):
        if ev[0] == E.EV_RECEIVED and ev[2] == "topside":
            self.received.append(self.w.now())
            self._acoustic(self.vehicle, ev)

    def _acoustic(self, side, ev):
        try:
            items = R.CATALOG.unpack(bytes(ev[4]))
        except AcommError:
            return
        side.acoustic_in(self.w.now(), items, len(ev) > 5 and bool(ev[5]))

    def _send(self, sn, dst, side, now):
        for name, values in side.take_acoustic():
            data = R.CATALOG.pack([(name, values)])
            k = kind(name, values)
            prio, life, ack = SENDING[k]
            rid = sn.node.send("acoustic", dst, data, int(life), prio, ack, now=now)
            if sn is self.top:
                self._names[rid] = k
                if k in UPLINK:
                    self._stick_rid = rid
            self.w.wake(sn)

    def poll(self, now):
        """The World's task: every 10 ms."""
        self._gcs(now)
        self.topside.poll(now, self._stick_rid is None)
        self.topside.take_mavlink()  # to the GCS: nothing reads it here
        self._send(self.top, "vehicle", self.topside, now)
        self.vehicle.poll(now)
        to_ap = [self.ap_end.feed(self.veh_end.encode(m)) for m in self.vehicle.take_mavlink()]
        self._autopilot(now, [m for ms in to_ap for m in ms])
        self._send(self.veh, "topside", self.vehicle, now)
        return None
