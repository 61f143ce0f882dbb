# The two MAVLink programs at the ends of `acomm bridge mavlink` when no
# vehicle and no QGroundControl are at hand (`acomm bench mavlink`, and the
# bridge's tests): a scripted autopilot standing in for ArduSub and a
# scripted ground station standing in for QGroundControl, both pymavlink on
# real UDP sockets on loopback, each in its own thread.
#
# The autopilot: HEARTBEAT every second (an ArduPilot submarine, armed flag
# and custom mode), ATTITUDE, VFR_HUD and SYS_STATUS twice a second; every
# MANUAL_CONTROL recorded with its arrival time; arm, disarm and DO_SET_MODE
# carried out and acknowledged (ACCEPTED; silent=True: never answered); and
# ArduSub's pilot-input failsafe counted: a gap of FS_PILOT_TIMEOUT (3 s,
# its default) between MANUAL_CONTROLs is a trip.
# The GCS: HEARTBEAT every second and MANUAL_CONTROL at `rate_hz` (50 Hz,
# a busy joystick) with its current stick; COMMAND_LONG on request; every
# message it gets recorded. Both answer whoever spoke to them last, as
# QGroundControl and ArduSub's GCS link do.

import select
import socket
import threading
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

FS_PILOT_TIMEOUT_S = 3.0  # ArduSub's default (its parameter documentation)


class _Peer(threading.Thread):
    def __init__(self, sysid, compid, port=0):
        threading.Thread.__init__(self, daemon=True)
        self.mav = mavlink.MAVLink(None, sysid, compid)
        self.mav.robust_parsing = True
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.port = self.sock.getsockname()[1]
        self.peer = None  # the address last heard from
        self.lock = threading.Lock()
        self.got = []  # (monotonic s, message)
        self._halt = False

    def send(self, msg):
        with self.lock:
            data = msg.pack(self.mav)
            self.mav.seq = (self.mav.seq + 1) % 256
        self.send_raw(data)

    def send_raw(self, data):
        if self.peer is not None:
            try:
                self.sock.sendto(data, self.peer)
            except OSError:
                pass

    def run(self):
        next_tick = time.monotonic()
        while not self._halt:
            r, _, _ = select.select([self.sock], [], [], max(0.0, next_tick - time.monotonic()))
            now = time.monotonic()
            if r:
                try:
                    data, self.peer = self.sock.recvfrom(65535)
                except OSError:
                    continue
                for m in self.mav.parse_buffer(data) or []:
                    if m.get_type() != "BAD_DATA":
                        with self.lock:
                            self.got.append((now, m))
                        self.on_message(now, m)
            if now >= next_tick:
                next_tick = now + self.tick(now)

    def on_message(self, now, m):
        pass

    def messages(self, kind):
        with self.lock:
            return [(t, m) for t, m in self.got if m.get_type() == kind]

    def stop(self):
        self._halt = True
        self.join(2)
        self.sock.close()


class Autopilot(_Peer):
    def __init__(self, silent=False):
        _Peer.__init__(self, 1, mavlink.MAV_COMP_ID_AUTOPILOT1)
        self.silent = silent
        self.armed = False
        self.mode = mavlink.SUB_MODE_MANUAL
        self.depth = 3.0
        self.heading = 90
        self.manual = []  # (monotonic s, (x, y, z, r, s, t))
        self.pilot_failsafe_trips = 0
        self._last_manual = None
        self._beat = self._telemetry = 0.0

    def on_message(self, now, m):
        t = m.get_type()
        if t == "MANUAL_CONTROL":
            if self._last_manual is not None and now - self._last_manual >= FS_PILOT_TIMEOUT_S:
                self.pilot_failsafe_trips += 1
            self._last_manual = now
            with self.lock:
                self.manual.append((now, (m.x, m.y, m.z, m.r, m.s, m.t)))
        elif t == "COMMAND_LONG" and not self.silent:
            result = mavlink.MAV_RESULT_ACCEPTED
            if m.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
                self.armed = m.param1 >= 0.5
            elif m.command == mavlink.MAV_CMD_DO_SET_MODE:
                self.mode = int(m.param2)
            else:
                result = mavlink.MAV_RESULT_UNSUPPORTED
            self.send(self.mav.command_ack_encode(m.command, result))

    def tick(self, now):
        if self._last_manual is not None and now - self._last_manual >= FS_PILOT_TIMEOUT_S:
            self.pilot_failsafe_trips += 1
            self._last_manual = None  # one trip until MANUAL_CONTROL comes back
        if now - self._beat >= 1.0:
            self._beat = now
            base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            self.send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                                self.mode, mavlink.MAV_STATE_ACTIVE))
        if now - self._telemetry >= 0.5:
            self._telemetry = now
            ms = int(now * 1000) & 0xFFFFFFFF
            self.send(self.mav.attitude_encode(ms, 0.05, -0.1, self.heading * 0.0174533, 0, 0, 0))
            self.send(self.mav.vfr_hud_encode(0, 0, self.heading, 0, -self.depth, 0))
            self.send(self.mav.sys_status_encode(0, 0, 0, 0, 15800, -1, 77, 0, 0, 0, 0, 0, 0))
        return 0.05

    def manual_since(self, t0):
        with self.lock:
            return [(t, v) for t, v in self.manual if t >= t0]


class GroundStation(_Peer):
    def __init__(self, rate_hz=50.0, target=1):
        _Peer.__init__(self, 255, mavlink.MAV_COMP_ID_MISSIONPLANNER)
        self.period = 1.0 / rate_hz
        self.target = target
        self.stick = (0, 0, 500, 0, 0, 0)  # x, y, z, r, s (pitch), t (roll)
        self.joystick = True  # False: the joystick is unplugged, no MANUAL_CONTROL
        self._beat = 0.0

    def move(self, x=0, y=0, z=500, r=0, s=0, t=0):
        self.stick = (x, y, z, r, s, t)

    def command(self, command, p1=0.0, p2=0.0, confirmation=0):
        self.send(self.mav.command_long_encode(self.target, 1, command, confirmation, p1, p2, 0, 0, 0, 0, 0))

    def tick(self, now):
        if self.peer is None:
            return 0.05  # nobody has spoken yet: a GCS on udpin waits for its vehicle
        if now - self._beat >= 1.0:
            self._beat = now
            self.send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                mavlink.MAV_STATE_ACTIVE))
        if self.joystick:
            x, y, z, r, s, t = self.stick
            self.send(self.mav.manual_control_encode(self.target, x, y, z, r, 0, enabled_extensions=3, s=s, t=t))
        return self.period

    def acks(self):
        return [(t, m.command, m.result) for t, m in self.messages("COMMAND_ACK")]
