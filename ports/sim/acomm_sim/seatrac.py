# An emulated Blueprint Subsea SeaTrac beacon (X150 USBL or X110 modem) that
# speaks the real serial protocol, so acomm's driver, a terminal program or
# someone else's software can drive it as they would a beacon on a USB-serial
# adapter. Sans-IO like the drivers: feed(now, bytes), poll(now),
# take_output(). Beacons exchange acoustic packets through a shared medium
# (acomm_sim.medium); the acoustic side lives in seatrac_xcvr.
#
# Commands: SYS_ALIVE, SYS_INFO, SYS_REBOOT (check word 0x6A95), STATUS,
# SETTINGS_GET/SET/LOAD/SAVE/RESET, XCVR_STATUS, PING_SEND, DAT_SEND,
# DAT_QUEUE_SET/CLR/STATUS (the reply packet, in seatrac_xcvr; answers:
# STATUS, STATUS, PACKET_LEN as UNIZG-FER's driver reads them).
# Input: '#' lines, uppercase hex, CR, LF or both. A line with a bad CRC,
# bad hex or an unknown CID is dropped without an answer (what real beacons
# do was not confirmed; see docs/drivers.md).
#
# Fault modes, for driver tests: noise bytes, a wrong checksum or a
# truncated line on the next output line(s), a command that is never
# answered, and a reboot at any moment (mid-transfer included), with its
# power-up text.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import seatrac_wire as w
from acomm.drivers import seatrac_codes as sc

from acomm.drivers.base import SansIO

from .faults import FaultModes, digit_off
from .seatrac_xcvr import Transceiver

BANNER = (
    b"Blueprint Subsea SeaTrac (acomm emulator)",
    b"Bootloader OK, starting application",
)


def default_settings(beacon_id):
    # SETTINGS_T in the 110-byte layout DUNE uses (see docs/drivers.md)
    s = bytearray(110)
    s[0] = 0  # STATUSMODE manual
    s[1] = 0x07  # STATUS_OUTPUT: environment, attitude, mag cal
    s[2] = 0x0D  # main UART 115200
    s[3] = 0x0D
    s[33:35] = (350).to_bytes(2, "little")  # salinity 35.0 ppt
    s[35:37] = (15000).to_bytes(2, "little")  # VOS 1500.0 m/s
    s[95] = 0x01  # XCVR_FLAGS: USBL uses AHRS
    s[96] = beacon_id
    s[97:99] = (1000).to_bytes(2, "little")  # xcvr_range_tmo, m
    s[99:101] = (10).to_bytes(2, "little")  # xcvr_resp_time, ms
    return s


class SeatracEmulator(SansIO, FaultModes):
    def __init__(
        self,
        medium,
        beacon_id=1,
        now=0,
        part=sc.PART_X150,
        serial=3689,
        uptime_ms=0,
        mtu=30,
        local_flag=False,
        packet_ms=500,
        byte_ms=80,
        turnaround_ms=300,
        range_noise_m=0.0,
        bearing_noise_deg=0.0,
        seed=1,
        banner=BANNER,
        boot_message=None,
        boot_ms=1000,
        hear_all=True,
    ):
        SansIO.__init__(self)
        self.medium = medium
        self.part = part
        self.serial = serial
        self.mtu = mtu
        self.banner = banner
        self.boot_message = boot_message  # None, sc.CID_SYS_ALIVE or sc.CID_SYS_INFO
        self.boot_ms = boot_ms
        # firmware as in the manual's SYS_INFO example
        self.boot_fw = (0xFF, 912, 1, 0, 361, 0xBFC5FAB7)
        self.main_fw = (0xFF, 913, 1, 0, 1914, 0xA9630475)
        # the beacon's own sensors, in wire units
        self.env = [12473, 194, 8, 0, 15000]  # mV, 0.1 C, mbar, dm, 0.1 m/s
        self.attitude = [0, 0, 0]  # yaw, pitch, roll in 0.1 degree
        self.mag_cal = [3, 0xFF, 1067, 94]
        self.rssi = -650  # 0.1 dB, reported in every fix
        self.eeprom = default_settings(beacon_id)
        self.settings = bytearray(self.eeprom)
        self.beacon_id = beacon_id
        self._boot_at = ticks_add(now, -uptime_ms)
        self._booting_until = None
        self._now = now
        self._dec = w.LineReader(sc.SYNC_CMD, self)
        self._out = bytearray()
        self._line = bytearray(2 * sc.MAX_MSG + 8)
        self._faults = []  # [kind, cid or None, count, execute]
        self._mute = 0  # CID whose answer is swallowed
        self.commands = {}  # CID -> count, for tests
        self.ignored = 0  # bad lines and unknown commands
        self.xcvr = Transceiver(
            self, medium, packet_ms, byte_ms, turnaround_ms, range_noise_m, seed, local_flag, hear_all,
            bearing_noise_deg
        )
        medium.attach(beacon_id, self.xcvr)

    @property
    def usbl(self):
        return self.part == sc.PART_X150

    def uptime_ms(self, now):
        return ticks_diff(now, self._boot_at)

    # -- the serial port -----------------------------------------------------
    def feed(self, now, data):
        self._now = now
        if self._booting_until is not None:
            return  # the port is closed while the beacon restarts
        self._dec.feed(data)

    def poll(self, now):
        self._now = now
        self.medium.poll(now)
        if self._still_booting(now):
            return
        self.xcvr.poll(now)

    def emit(self, cid, payload):
        # One '$' line, with any output fault that applies to it.
        if self._mute and cid == self._mute:
            self._mute = 0
            return
        msg = bytearray(1 + len(payload))
        msg[0] = cid
        msg[1:] = payload
        line = self._line
        k = w.encode_into(line, sc.SYNC_RSP, msg, len(msg))
        f = self._fault(("corrupt", "truncate"), cid)
        if f is not None and f[0] == "corrupt":
            digit_off(line, k - 3)
        elif f is not None:
            keep = k // 2
            line[keep] = 13
            line[keep + 1] = 10
            k = keep + 2 if f[3] else keep
        self._out.extend(memoryview(line)[:k])

    # -- fault modes -----------------------------------------------------------
    # (corrupt_next, truncate_next, swallow_next: acomm_sim.faults). Keys
    # are CIDs; corrupt gives a wrong CRC.

    def reboot(self, now):
        # Power cycle or watchdog: everything in flight is forgotten, the
        # port goes quiet, then the power-up text appears.
        self._start_boot(now)
        self._boot_at = now
        self._dec.reset()
        self._mute = 0
        self.settings = bytearray(self.eeprom)
        self.beacon_id = self.settings[96]
        self._leave_medium(now)

    def _booted(self, now):
        self._join_medium(self.beacon_id)
        self._print_banner()
        if self.boot_message == sc.CID_SYS_ALIVE:
            self._alive()
        elif self.boot_message == sc.CID_SYS_INFO:
            self._info()

    # -- commands ----------------------------------------------------------------
    def on_junk(self, kind):
        self.ignored += 1

    def on_message(self, b, n):
        if self._booting_until is not None:
            return  # the rest of a chunk that arrived with SYS_REBOOT
        now = self._now
        cid = b[0]
        self.commands[cid] = self.commands.get(cid, 0) + 1
        f = self._fault(("swallow",), cid)
        if f is not None:
            if not f[3]:
                return
            self._mute = cid
        if cid == sc.CID_SYS_ALIVE:
            self._alive()
        elif cid == sc.CID_SYS_INFO:
            self._info()
        elif cid == sc.CID_SYS_REBOOT:
            if n < 3:
                self._status(cid, sc.CST_CMD_PARAM_MISSING)
            elif w.u16(b, 1) != sc.REBOOT_CHECK:
                self._status(cid, sc.CST_CMD_PARAM_INVALID)
            else:
                self._status(cid, sc.CST_OK)
                self.reboot(now)
        elif cid == sc.CID_STATUS:
            self._status_report(b[1] if n >= 2 and b[1] else self.settings[1])
        elif cid == sc.CID_SETTINGS_GET:
            self.emit(cid, self.settings)
        elif cid == sc.CID_SETTINGS_SET:
            if n - 1 < len(self.settings):
                self._status(cid, sc.CST_CMD_PARAM_MISSING)
            elif n - 1 > len(self.settings) or not 1 <= b[97] <= 15:
                self._status(cid, sc.CST_CMD_PARAM_INVALID)
            else:
                self.settings[:] = memoryview(b)[1:n]
                self._status(cid, sc.CST_OK)
        elif cid == sc.CID_SETTINGS_LOAD:
            self.settings = bytearray(self.eeprom)
            self._status(cid, sc.CST_OK)
        elif cid == sc.CID_SETTINGS_SAVE:
            self.eeprom = bytearray(self.settings)
            self._status(cid, sc.CST_OK)
        elif cid == sc.CID_SETTINGS_RESET:
            self.settings = default_settings(self.beacon_id)
            self._status(cid, sc.CST_OK)
        elif cid == sc.CID_XCVR_STATUS:
            self._status(cid, self.xcvr.state(now))
        elif cid == sc.CID_PING_SEND:
            st = self.xcvr.ping_send(now, b, n)
            self.emit(cid, bytes((st, b[1] if n >= 2 else 0)))
            self.xcvr.started(now, st)
        elif cid == sc.CID_DAT_SEND:
            st = self.xcvr.dat_send(now, b, n)
            self.emit(cid, bytes((st, b[1] if n >= 2 else 0)))
            self.xcvr.started(now, st)
        elif cid == sc.CID_DAT_QUEUE_SET:
            self._status(cid, self.xcvr.queue_set(b, n))
        elif cid == sc.CID_DAT_QUEUE_CLR:
            self.xcvr.queued = None
            self._status(cid, sc.CST_OK)
        elif cid == sc.CID_DAT_QUEUE_STATUS:
            q = self.xcvr.queued
            self._status(cid, len(q[1]) if q is not None else 0)
        else:
            self.ignored += 1
        if self._mute == cid:
            self._mute = 0  # the command had no answer to swallow

    def _status(self, cid, st):
        self.emit(cid, bytes((st,)))

    def _alive(self):
        self.emit(sc.CID_SYS_ALIVE, (self.uptime_ms(self._now) // 1000).to_bytes(4, "little"))

    def _info(self):
        p = bytearray(38)
        p[0:4] = (self.uptime_ms(self._now) // 1000).to_bytes(4, "little")
        p[4] = 1  # running the application section
        p[5:7] = self.part.to_bytes(2, "little")
        p[7] = 1  # hardware revision
        p[8:12] = self.serial.to_bytes(4, "little")
        for o, fw in ((16, self.boot_fw), (27, self.main_fw)):
            p[o] = fw[0]
            p[o + 1 : o + 3] = fw[1].to_bytes(2, "little")
            p[o + 3] = fw[2]
            p[o + 4] = fw[3]
            p[o + 5 : o + 7] = fw[4].to_bytes(2, "little")
            p[o + 7 : o + 11] = fw[5].to_bytes(4, "little")
        self.emit(sc.CID_SYS_INFO, p)

    def _status_report(self, flags):
        # Groups in bit order; the calibration and raw AHRS groups are
        # reported as zeros of the right size.
        p = bytearray()
        p.append(flags)
        p.extend((self.uptime_ms(self._now) & 0xFFFFFFFF).to_bytes(4, "little"))
        p.extend(bytes(4))
        if flags & 0x01:
            e = self.env
            p.extend(_le(e[0], 2) + _le(e[1], 2) + _le(e[2], 4) + _le(e[3], 4) + _le(e[4], 2))
        if flags & 0x02:
            a = self.attitude
            p.extend(_le(a[0], 2) + _le(a[1], 2) + _le(a[2], 2))
        if flags & 0x04:
            m = self.mag_cal
            p.extend(bytes((m[0], m[1])) + _le(m[2], 4) + bytes((m[3],)))
        for bit, size in ((0x08, 12), (0x10, 18), (0x20, 36)):
            if flags & bit:
                p.extend(bytes(size))
        self.emit(sc.CID_STATUS, p)


def _le(v, n):
    # little-endian two's complement of n bytes (MicroPython's int.to_bytes
    # has no `signed`)
    return (v & ((1 << (8 * n)) - 1)).to_bytes(n, "little")
