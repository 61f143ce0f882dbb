# `acomm emulate <modem> --link PATH`: an emulated modem on a pseudo-terminal,
# so that acomm's drivers, someone else's software or a terminal program can
# talk to it exactly as to a modem behind a USB-serial adapter.
#
# The emulators themselves are sans-IO (ports/sim/acomm_sim); this module is
# only their I/O: it makes a pty per modem (a symlink to its slave at the
# path given), optional TCP listeners (EvoLogics modems are reached over TCP
# port 9200 as well as serial), and a select() loop that feeds what arrives
# to the emulator with the current time, polls it, and writes its output.
#
# All modems of one process share one acoustic medium. The first is the one
# at --link; each --peer adds another, on its own pty when a path is given,
# otherwise headless (it still acknowledges and answers pings, as a modem in
# the water does). --time-scale runs the emulated world faster than real
# time (airtimes and propagation shrink; useful for tests). --log FILE
# writes every byte that crosses the first modem's port, each way, with its
# real time in ms (acomm_cpython.emulate.capture), for `acomm replay`.
# add_service() adds one of the Iridium gateway's shore services
# (directipgw, rockblockgw), pumped on the emulated clock at every step.

import select
import socket
import time

from .pty import Pty

# name -> (module, class, default TCP port or None)
MODEMS = {
    "seatrac": ("acomm_sim.seatrac", "SeatracEmulator", None),
    "evologics": ("acomm_sim.evologics", "EvologicsEmulator", 9200),
    "micromodem": ("acomm_sim.micromodem", "MicroModemEmulator", None),
    "benthos": ("acomm_sim.benthos", "BenthosEmulator", None),
    "iridium": ("acomm_sim.iridium", "IridiumEmulator", None),
    "gsm": ("acomm_sim.gsm", "GsmEmulator", None),
}

_CHUNK = 4096


def emulator_class(modem):
    if modem not in MODEMS:
        raise ValueError("unknown modem %r (one of %s)" % (modem, ", ".join(sorted(MODEMS))))
    mod, cls, _ = MODEMS[modem]
    m = __import__(mod, None, None, [cls])
    return getattr(m, cls)


def parse_peer(text):
    # "ADDR" or "ADDR:PATH" or "ADDR:PATH:DISTANCE" ("ADDR::DISTANCE" headless)
    parts = text.split(":")
    addr = int(parts[0])
    path = parts[1] if len(parts) > 1 and parts[1] else None
    dist = float(parts[2]) if len(parts) > 2 and parts[2] else None
    return addr, path, dist


class TcpPort:
    # A listening socket whose clients all share one modem, as on an
    # EvoLogics modem: what any client writes goes to the modem, and what the
    # modem says goes to every client.
    def __init__(self, host, port):
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind((host, port))
        self.server.listen(4)
        self.server.setblocking(False)
        self.port = self.server.getsockname()[1]
        self.clients = []

    def accept(self):
        try:
            c, _ = self.server.accept()
        except (BlockingIOError, OSError):
            return
        c.setblocking(False)
        c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.clients.append(c)

    def read(self, c):
        try:
            data = c.recv(_CHUNK)
        except BlockingIOError:
            return b""
        except OSError:
            data = b""
        if not data:
            self.drop(c)
        return data

    def write(self, data):
        for c in list(self.clients):
            try:
                c.sendall(data)
            except OSError:
                self.drop(c)

    def drop(self, c):
        if c in self.clients:
            self.clients.remove(c)
        c.close()

    def close(self):
        for c in list(self.clients):
            self.drop(c)
        self.server.close()


class Station:
    # One emulated modem and the ports it is reached through.
    def __init__(self, emu, address, pty=None, tcp=None):
        self.emu = emu
        self.address = address
        self.pty = pty
        self.tcp = tcp


class EmulatorHost:
    def __init__(self, modem, link, address=1, peers=(), options=None, distance=100.0, loss=0.0,
                 seed=1, time_scale=1.0, tcp_port=None, tcp_host="127.0.0.1", incoming=(), log=None):
        from acomm_sim.medium import Medium

        cls = emulator_class(modem)
        self.modem = modem
        self.log = log  # a capture.CaptureWriter for the first modem's port, or None
        self.time_scale = float(time_scale)
        self._t0 = time.monotonic()
        self.medium = Medium(default_distance=distance, loss=loss, seed=seed)
        self.stations = []
        self.services = []
        opts = dict(options or {})
        now = self.now()
        try:
            tcp = TcpPort(tcp_host, tcp_port) if tcp_port is not None else None
            self.stations.append(Station(cls(self.medium, address, now=now, **opts), address, Pty(link), tcp))
            for addr, path, dist in peers:
                emu = cls(self.medium, addr, now=now, **opts)
                self.stations.append(Station(emu, addr, Pty(path) if path else None))
                if dist is not None:
                    self.medium.set_distance(address, addr, dist)
            for data in incoming:
                # --mt: messages waiting for the first modem (Iridium, GSM)
                self.stations[0].emu.queue_incoming(now, data)
        except BaseException:
            self.close()
            raise

    def add_service(self, make):
        """make(network, now) -> a service with pump(now) and close(), on the Iridium gateway of
        this host's modems; -> the service."""
        from acomm_sim.iridium_net import network_of

        svc = make(network_of(self.medium), self.now())
        self.services.append(svc)
        return svc

    def _log(self, st, to, data):
        if self.log is not None and st is self.stations[0]:
            self.log.record((time.monotonic() - self._t0) * 1000, to, data)

    def now(self):
        return int((time.monotonic() - self._t0) * 1000 * self.time_scale) & 0x3FFFFFFF

    @property
    def device(self):
        return self.stations[0].pty.device

    def step(self, timeout_s=0.01):
        rd = []
        for st in self.stations:
            if st.pty:
                rd.append(st.pty.master)
            if st.tcp:
                rd.append(st.tcp.server)
                rd.extend(st.tcp.clients)
        try:
            r, _, _ = select.select(rd, [], [], timeout_s)
        except (OSError, ValueError):
            r = []
        now = self.now()
        for st in self.stations:
            if st.pty and st.pty.master in r:
                data = st.pty.read()
                if data:
                    self._log(st, "device", data)
                    st.emu.feed(now, data)
            if st.tcp:
                if st.tcp.server in r:
                    st.tcp.accept()
                for c in list(st.tcp.clients):
                    if c in r:
                        data = st.tcp.read(c)
                        if data:
                            self._log(st, "device", data)
                            st.emu.feed(now, data)
        for st in self.stations:
            st.emu.poll(now)
        for svc in self.services:
            svc.pump(now)
        self.medium.poll(now)
        for st in self.stations:
            out = st.emu.take_output()
            if out:
                self._log(st, "host", out)
            if st.pty:
                if out:
                    st.pty.write(out)
                else:
                    st.pty.flush()
            if out and st.tcp:
                st.tcp.write(out)

    def run(self, stop=None):
        while stop is None or not stop():
            self.step()

    def close(self):
        for svc in self.services:
            svc.close()
        self.services = []
        for st in self.stations:
            if st.pty:
                st.pty.close()
            if st.tcp:
                st.tcp.close()
        self.stations = []
        if self.log is not None:
            self.log.close()
            self.log = None
