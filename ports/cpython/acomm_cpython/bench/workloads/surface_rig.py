# The surface path end to end, in one process on real time, for `acomm bench
# surface` and tests/cpython/test_shore_iridium.py:
#
#   diver --TCP--> buoy --SBD--> emulated 9603 (a pty, acomm emulate's host,
#   on its own thread) --> gateway --DirectIP or RockBLOCK POST--> shore
#
# and back: the shore's packets leave as MT messages (DirectIP MT or the
# RockBLOCK MT API), wait at the gateway, and the buoy collects them at its
# next session (a ring alert brings it at once). Every node runs acomm's
# real drivers, link layer and store-and-forward transport; the diver
# reaches shore by a static route through the buoy. The emulated world runs
# time_scale times faster than real time (sessions, network latency and the
# gateway's retries shrink); the nodes run on real time.

import os
import threading
import time

from acomm.drivers.iridium import IridiumDriver
from acomm.events import DELIVERED, EV_PACKET, EV_PACKET_STATUS, is_final
from acomm.node import Node

from ...emulate.directipgw import DirectIpGateway
from ...emulate.host import EmulatorHost
from ...emulate.rockblockgw import RockblockGateway, public_test_pem
from ...hosttransport import HostTransport
from ...shore.spec import add_shore_link
from ...streams import open_serial
from ...tcp import tcp_client_link, tcp_server_link

NAMES = {"buoy": 1, "diver": 2, "shore": 3}
CREDENTIALS = ("buoyteam", "test-password")


def write_private(path, text):
    """Writes a file only its owner can read (a key or credentials file) -> path."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(text)
    return path


class SurfaceRig:
    """The three nodes, the emulated modem and the gateway with one shore service ("directip" or
    "rockblock"). key: a network key (bytes) every node seals its frames with, or None. close()
    at the end."""

    def __init__(self, workdir, service, time_scale=20.0, retry_s=60.0, key=None):
        self.service = service
        self.key = key
        self.time_scale = time_scale
        self.events = {n: [] for n in NAMES}
        self.nodes = {}
        self._closers = []
        self._stop = []
        try:
            self._build(workdir, service, time_scale, int(retry_s * 1000))
        except BaseException:
            self.close()
            raise

    def _node(self, name):
        n = Node(name, NAMES[name], listener=self.events[name].append)
        for k, v in NAMES.items():
            n.names.add(k, v)
        if self.key is not None:
            from acomm.frame.auth import Auth

            n.set_auth(Auth(self.key))
        self.nodes[name] = n
        return n

    def _build(self, workdir, service, time_scale, retry_ms):
        host = self.host = EmulatorHost("iridium", os.path.join(workdir, "sbd-" + service), 1, time_scale=time_scale)
        self._closers.append(host.close)
        shore = self._node("shore")
        if service == "directip":
            _, self.port = add_shore_link(shore, "directip:127.0.0.1:0,gateway=127.0.0.1")
            addr = self.port.address
            self.gateway = host.add_service(lambda net, now: DirectIpGateway(net, addr, ("127.0.0.1", 0), now,
                                                                                 retry_ms))
            self.port.mt = self.gateway.mt_address
        else:
            key = write_private(os.path.join(workdir, "rock7-test-public.pem"), public_test_pem())
            _, self.port = add_shore_link(shore, "rockblock:127.0.0.1:0,key=%s" % key)
            url = "http://127.0.0.1:%d/mo" % self.port.address[1]
            self.gateway = host.add_service(lambda net, now: RockblockGateway(net, url, ("127.0.0.1", 0), CREDENTIALS,
                                                                                  now, retry_ms))
            self.port.mt_url = "http://127.0.0.1:%d/rockblock/MT" % self.gateway.mt_address[1]
            self.port.credentials = CREDENTIALS
        self._closers.append(self.port.close)
        HostTransport.of(shore)
        self._thread = threading.Thread(target=host.run, args=(lambda: self._stop,), daemon=True)
        self._thread.start()
        buoy = self._node("buoy")
        serial = open_serial(host.stations[0].pty.link, 19200)
        self._closers.append(serial.close)
        buoy.add_link("satellite", IridiumDriver(), serial, medium="satellite", advert_period_ms=3600000,
                      ack_timeout_ms=60000)
        _, server = tcp_server_link(buoy, "acoustic", bind=("127.0.0.1", 0), advert_period_ms=2000)
        self._closers.append(server.close)
        HostTransport.of(buoy)
        diver = self._node("diver")
        _, client = tcp_client_link(diver, "127.0.0.1", server.address[1], "acoustic", advert_period_ms=2000)
        self._closers.append(client.close)
        HostTransport.of(diver, routes={"shore": "buoy"})

    def step(self):
        for n in self.nodes.values():
            n.step()

    def run_until(self, cond, timeout_s):
        """Steps the nodes until cond() -> True, or timeout_s of real time -> False."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            self.step()
            if cond():
                return True
            time.sleep(0.002)
        return False

    def got(self, name, data, authed=None):
        """Whether node `name` has received a packet holding data (authed: True, only one whose
        every fragment's tag verified)."""
        return any(ev[0] == EV_PACKET and ev[3] == data and (authed is None or ev[4:5] == (authed,))
                   for ev in self.events[name])

    def status(self, name, pid):
        """The final status of node `name`'s packet pid, or None."""
        for ev in self.events[name]:
            if ev[0] == EV_PACKET_STATUS and ev[1] == pid and is_final(ev[2]):
                return ev[2]
        return None

    def send(self, src, dst, data, lifespan_s=3600):
        """A packet from src to dst by src's transport -> its id."""
        n = self.nodes[src]
        return n.transport.send(n.clock(), dst, data, lifespan_s)

    def report(self, data, timeout_s=60):
        """A diver's packet to shore -> the real seconds until the shore has it, or None."""
        t0 = time.monotonic()
        self.send("diver", "shore", data)
        return time.monotonic() - t0 if self.run_until(lambda: self.got("shore", data), timeout_s) else None

    def command(self, data, timeout_s=60):
        """A packet from shore to the buoy -> the real seconds until the buoy has it and the shore
        its acknowledgement (status delivered), or None."""
        t0 = time.monotonic()
        pid = self.send("shore", "buoy", data)
        ok = self.run_until(lambda: self.got("buoy", data) and self.status("shore", pid) is not None, timeout_s)
        return time.monotonic() - t0 if ok and self.status("shore", pid) == DELIVERED else None

    def close(self):
        self._stop.append(1)
        if getattr(self, "_thread", None) is not None:
            self._thread.join(5)
        for c in reversed(self._closers):
            try:
                c()
            except OSError:
                pass
        self._closers = []


def forge_posts(addr, imei, n):
    """n forged MO POSTs to a RockBLOCK shore at addr, as an attacker without Rock7's key would
    send them: a signed POST's data changed, a signature altered, no signature, in turn.
    -> how many were refused (HTTP 401)."""
    import http.client

    from ...emulate.rock7_testkey import PRIVATE_PEM
    from ...shore import jwt_rs256
    from ...shore import rockblock as rb

    key = jwt_rs256.private_key(PRIVATE_PEM)
    refused = 0
    for i in range(n):
        f = {"imei": imei, "serial": "0000001", "momsn": str(60000 + i), "transmit_time": "26-11-27 10:00:00",
             "iridium_latitude": "41.1", "iridium_longitude": "-8.6", "iridium_cep": "4", "data": "0a0b"}
        body = rb.form(rb.mo_form(f, key))
        if i % 3 == 0:
            body["data"] = "ff00"  # a command slipped into a signed POST
        elif i % 3 == 1:
            body["JWT"] = body["JWT"][:-8] + ("A" * 8 if body["JWT"][-8:] != "A" * 8 else "B" * 8)
        else:
            del body["JWT"]
        c = http.client.HTTPConnection(addr[0], addr[1], timeout=10)
        try:
            c.request("POST", "/mo", "&".join("%s=%s" % kv for kv in body.items()),
                      {"Content-Type": "application/x-www-form-urlencoded"})
            refused += c.getresponse().status == 401
        finally:
            c.close()
    return refused
