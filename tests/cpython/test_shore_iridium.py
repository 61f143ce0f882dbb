# The shore end of the satellite link on real sockets, real HTTP and a real
# pseudo-terminal: a diver's packet reaches a shore node with no modem
# through the buoy, its SBD session, the emulated gateway and DirectIP, and
# again through the RockBLOCK POST; a packet from shore reaches the buoy as
# an MT message and its acknowledgement comes back (the surface rig, one
# process). The shore is down for ten emulated minutes and the gateway's
# retries lose nothing (the gateway on a simulated clock, the shore on real
# sockets). Bad input to the shore (DirectIP and POST) and to the gateway's
# MT services is refused and counted by reason, answered as the protocol
# allows, and the shore goes on. No timing is asserted.
import http.client
import socket
import sys
import threading
import time

import pytest

pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.node import Node  # noqa: E402
from acomm_cpython.bench.workloads.surface_rig import CREDENTIALS, SurfaceRig, write_private  # noqa: E402
from acomm_cpython.emulate.directipgw import DirectIpGateway  # noqa: E402
from acomm_cpython.emulate.rock7_testkey import PRIVATE_PEM  # noqa: E402
from acomm_cpython.emulate.rockblockgw import RockblockGateway, public_test_pem  # noqa: E402
from acomm_cpython.shore import directip as dip  # noqa: E402
from acomm_cpython.shore import jwt_rs256  # noqa: E402
from acomm_cpython.shore import rockblock as rb  # noqa: E402
from acomm_cpython.shore.spec import add_shore_link  # noqa: E402
from acomm_sim.iridium import IridiumEmulator  # noqa: E402
from acomm_sim.iridium_net import IridiumNetwork  # noqa: E402

IMEI = "300234010000001"
TIMEOUT_S = 30


@pytest.mark.parametrize("service", ["directip", "rockblock"])
def test_a_divers_packet_reaches_shore_and_a_command_comes_back_acknowledged(tmp_path, service):
    rig = SurfaceRig(str(tmp_path), service, time_scale=20)
    try:
        assert rig.report(b"diver: all well at 12 m", TIMEOUT_S) is not None, (rig.port.refused, rig.gateway.outbox.stats)
        assert rig.command(b"shore: surface now", TIMEOUT_S) is not None, rig.port.stats
        assert rig.port.refused == {} and rig.gateway.outbox.stats["dropped"] == 0
        assert rig.port.stats["mt_queued"] >= 1 and rig.port.stats["mt_refused"] == 0
    finally:
        rig.close()


def test_frames_sealed_by_the_buoy_stay_sealed_to_the_shore(tmp_path):
    rig = SurfaceRig(str(tmp_path), "directip", time_scale=20, key=bytes(range(16)))
    try:
        assert rig.report(b"sealed report", TIMEOUT_S) is not None
        assert rig.got("shore", b"sealed report", authed=True)
        assert rig.command(b"sealed command", TIMEOUT_S) is not None and rig.got("buoy", b"sealed command", True)
    finally:
        rig.close()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _shore(spec):
    got = []
    node = Node("shore", 3)
    link, port = add_shore_link(node, spec)
    node.links[link.name].driver.deliver = _spy(link.driver.deliver, got)
    return node, port, got


def _spy(fn, got):
    def deliver(now, imei, payload):
        got.append(payload)
        return fn(now, imei, payload)
    return deliver


@pytest.mark.parametrize("service", ["directip", "rockblock"])
def test_the_shore_down_for_ten_minutes_loses_nothing(tmp_path, service):
    net = IridiumNetwork()
    emu = IridiumEmulator(net, 1)
    port_no = _free_port()
    if service == "directip":
        gw = DirectIpGateway(net, ("127.0.0.1", port_no), None, 0, retry_ms=60000)
        spec = "directip:127.0.0.1:%d" % port_no
    else:
        gw = RockblockGateway(net, "http://127.0.0.1:%d/mo" % port_no, None, None, 0, retry_ms=60000)
        spec = "rockblock:127.0.0.1:%d,key=%s" % (port_no, write_private(str(tmp_path / "k.pem"), public_test_pem()))
    sent = [b"report %d" % i for i in range(5)]
    now = 0
    try:
        for i, data in enumerate(sent):
            net.mo(i * 1000, emu, data)  # five sessions hand the gateway five messages
            emu.momsn += 1

        def settle(t, step=lambda: None):
            # the outbox's attempt at t, waited for on real time
            gw.pump(t)
            end = time.monotonic() + 10
            while gw.outbox._busy and time.monotonic() < end:
                step()
                time.sleep(0.002)
                gw.pump(t)

        while now <= 600000:  # ten emulated minutes, nobody listening
            settle(now)
            now += 5000
        st = gw.outbox.stats
        assert st["delivered"] == 0 and st["attempts"] >= 10 and len(gw.outbox) == 5, st
        node, port, got = _shore(spec)
        try:
            end = time.monotonic() + TIMEOUT_S
            while len(got) < 5 and time.monotonic() < end:
                settle(now, node.step)
                node.step()  # the RockBLOCK port hands its inbox over here
                now += 60000
            assert got == sent, (got, gw.outbox.stats, gw.outbox.last_error)
            assert gw.outbox.stats["dropped"] == 0 and gw.outbox.stats["refused"] == 0 and len(gw.outbox) == 0
        finally:
            port.close()
    finally:
        gw.close()


def _exchange(node, data, close_after=False, wait_s=5.0):
    # one connection to the shore's DirectIP port: data in, the answer out
    s = socket.create_connection(node._test_addr, timeout=wait_s)
    s.setblocking(False)
    s.sendall(data)
    if close_after:
        s.close()
        for _ in range(20):
            node.step()
            time.sleep(0.005)
        return None
    got = b""
    end = time.monotonic() + wait_s
    while time.monotonic() < end:
        node.step()
        try:
            chunk = s.recv(64)
            if not chunk:
                break
            got += chunk
        except BlockingIOError:
            time.sleep(0.005)
        except ConnectionResetError:
            break  # closed unread: the not-a-gateway case
    s.close()
    return got


REFUSED = dip.encode_mo_confirmation(False)
TAKEN = dip.encode_mo_confirmation(True)


def test_bad_directip_input_is_refused_counted_and_told_and_the_shore_goes_on():
    node, port, got = _shore("directip:127.0.0.1:0,gateway=127.0.0.1")
    port.stall_ms = 300
    node._test_addr = port.address
    good = dip.encode_mo(1, IMEI, 0, 1, 0, 0, b"\x00")
    try:
        assert _exchange(node, good[:-3], close_after=True) is None
        assert _exchange(node, b"\x01\x00\x22" + b"\x01\x00\x1b" + b"\x00" * 31) == REFUSED
        assert _exchange(node, good[:1] + struct_len(len(good) - 3 + 6) + good[3:] + b"\x09\x00\x03abc") == REFUSED
        assert _exchange(node, good[:10], wait_s=3) == REFUSED  # stalls mid-message
        assert _exchange(node, good.replace(IMEI.encode(), b"30023401000000x")) == REFUSED
        assert port.refused == {"truncated": 1, "wrong IE length": 1, "unknown IE": 1, "stalled": 1, "bad IMEI": 1}
        assert _exchange(node, good) == TAKEN and got == [b"\x00"]
    finally:
        port.close()
    node, port, _ = _shore("directip:127.0.0.1:0,gateway=10.9.9.9")
    node._test_addr = port.address
    try:
        assert _exchange(node, good, wait_s=1) == b"" and port.refused == {"not a gateway": 1}
    finally:
        port.close()


def struct_len(n):
    return n.to_bytes(2, "big")


def _post(addr, body):
    c = http.client.HTTPConnection(addr[0], addr[1], timeout=10)
    try:
        c.request("POST", "/mo", body, {"Content-Type": "application/x-www-form-urlencoded"})
        return c.getresponse().status
    finally:
        c.close()


def _pumped(node, fn, *args):
    # fn on a thread while the node steps (the port hands the inbox over in pump)
    box = []
    t = threading.Thread(target=lambda: box.append(fn(*args)))
    t.start()
    while t.is_alive():
        node.step()
        time.sleep(0.005)
    node.step()
    return box[0]


def test_forged_stale_replayed_and_malformed_posts_are_refused_with_a_4xx_and_counted(tmp_path):
    key = write_private(str(tmp_path / "rock7.pem"), public_test_pem())
    node, port, got = _shore("rockblock:127.0.0.1:0,key=%s" % key)
    port.stall_s = 0.5
    priv = jwt_rs256.private_key(PRIVATE_PEM)

    def fields(momsn, data=b"\x01"):
        return {"imei": IMEI, "serial": "0000001", "momsn": str(momsn), "transmit_time": "26-11-27 10:00:00",
                "iridium_latitude": "41.1", "iridium_longitude": "-8.6", "iridium_cep": "4", "data": data.hex()}

    try:
        good = rb.mo_form(fields(1), priv)
        assert _pumped(node, _post, port.address, good) == 200
        assert _pumped(node, _post, port.address, good) == 409  # replayed
        forged = rb.form(rb.mo_form(fields(2, b"\x02"), priv))
        forged["data"] = "ff"
        forged = "&".join("%s=%s" % kv for kv in forged.items()).encode()
        assert _pumped(node, _post, port.address, forged) == 401  # the claims say 02
        sig = rb.form(rb.mo_form(fields(3), priv))
        sig["JWT"] = sig["JWT"][:-8] + ("A" * 8 if sig["JWT"][-8:] != "A" * 8 else "B" * 8)
        assert _pumped(node, _post, port.address, "&".join("%s=%s" % kv for kv in sig.items()).encode()) == 401
        assert _pumped(node, _post, port.address, rb.mo_form(fields(4), priv, now_s=time.time() - 3600)) == 401
        assert _pumped(node, _post, port.address, b"imei=%s&momsn=5&data=zz" % IMEI.encode()) == 400
        assert _pumped(node, _post, port.address, b"imei=%s&momsn=5&data=01" % IMEI.encode()) == 401  # unsigned
        assert _pumped(node, _post, port.address, b"%%%") == 400
        s = socket.create_connection(port.address)  # says 100 bytes, sends 10, stalls
        s.sendall(b"POST /mo HTTP/1.0\r\nContent-Length: 100\r\n\r\n0123456789")
        assert b" 408 " in _pumped(node, s.recv, 200)
        s.close()
        assert port.refused == {"replayed": 1, "claims differ": 1, "bad signature": 1, "stale": 1,
                                "malformed hex": 1, "unsigned": 1, "malformed form": 1, "stalled": 1}, port.refused
        assert got == [b"\x01"] and port.stats["mo_taken"] == 1
        assert _pumped(node, _post, port.address, rb.mo_form(fields(6, b"\x06"), priv)) == 200 and got[-1] == b"\x06"
        held = [port.slots.acquire(blocking=False) for _ in range(16)]  # every slot busy
        assert all(held)
        with socket.create_connection(port.address, timeout=5) as s:
            s.sendall(b"POST /mo HTTP/1.0\r\nContent-Length: 0\r\n\r\n")
            assert s.recv(100) == b""  # closed unread
        for _ in held:
            port.slots.release()
        assert port.refused["too many connections"] == 1
    finally:
        port.close()


def test_the_gateways_mt_services_answer_with_their_documented_codes():
    net = IridiumNetwork()
    emu = IridiumEmulator(net, 1)
    dgw = DirectIpGateway(net, None, ("127.0.0.1", 0), 0, stall_s=0.5)
    rgw = RockblockGateway(net, None, ("127.0.0.1", 0), CREDENTIALS, 0)
    stop = []

    def host():
        t = 0
        while not stop:
            dgw.pump(t)
            rgw.pump(t)
            net.poll(t)
            t += 10
            time.sleep(0.002)

    th = threading.Thread(target=host)
    th.start()

    def mt(data, imei=IMEI, raw=None):
        with socket.create_connection(dgw.mt_address, timeout=5) as s:
            s.sendall(raw if raw is not None else dip.encode_mt(9, imei, data))
            r = dip.Reader((dip.MT_CONFIRMATION,), 64)
            while True:
                ies = r.feed(s.recv(64))
                if ies is not None:
                    return dip.decode_mt_confirmation(ies)[3]

    def api(**f):
        c = http.client.HTTPConnection(*rgw.mt_address, timeout=5)
        c.request("POST", "/rockblock/MT", rb.mt_form(f.get("imei", IMEI), f.get("username", CREDENTIALS[0]),
                                                      f.get("password", CREDENTIALS[1]), b"").replace(
            b"data=", b"data=" + f.get("data", "01").encode()))
        return c.getresponse().read()

    try:
        assert mt(b"one") == 1 and mt(b"two") == 2
        assert mt(b"x", imei="30023401000000x") == -1
        assert mt(b"x", imei="300234010099999") == -2
        assert mt(b"x" * (emu.mt_max + 1)) == -3
        assert mt(None) == -4
        assert mt(None, raw=b"\x01\x00\x03\x41\x00\x01") == -7  # not a message
        assert mt(None, raw=b"\x01\x00\x40") == -7  # stalls
        for _ in range(net.mt_capacity - 2):
            mt(b"fill")
        assert mt(b"one too many") == -5
        assert api(password="wrong").startswith(b"FAILED,10,")
        assert api(imei="300234010099999").startswith(b"FAILED,11,")
        assert api(data="zz").startswith(b"FAILED,14,")
        assert api(data="00" * (emu.mt_max + 1)).startswith(b"FAILED,15,")
        assert api(data="").startswith(b"FAILED,16,")
        net.mt[IMEI] = []
        assert api().startswith(b"OK,") and net.queued(IMEI) == 1
        assert api().startswith(b"OK,") and net.queued(IMEI) == 2
        # the fields in the URL, as the service's page sends them; flush=yes empties the queue first
        c = http.client.HTTPConnection(*rgw.mt_address, timeout=5)
        c.request("POST", "/rockblock/MT?" + rb.mt_form(IMEI, *CREDENTIALS, b"\x07", flush=True).decode())
        assert c.getresponse().read().startswith(b"OK,") and net.mt[IMEI] == [b"\x07"]
        assert dgw.refused == {"truncated IE": 1, "stalled": 1}
    finally:
        stop.append(1)
        th.join()
        dgw.close()
        rgw.close()


def test_open_node_takes_the_same_iridium_texts():
    import asyncio

    from acomm import frame as fr
    from acomm_cpython.aio import open_node

    frame = fr.encode_raw(fr.Frame(fr.DATA, 1, 3, 0, b"hello shore"))

    def deliver(addr):
        with socket.create_connection(addr, timeout=5) as s:
            s.sendall(dip.encode_mo(1, IMEI, 0, 1, 0, 0, frame))
            return s.recv(64)

    async def main():
        async with open_node("shore", 3, iridium=["directip:127.0.0.1:0"], known={"buoy": 1}) as n:
            assert n.core.links["satellite"].medium == "satellite"
            answer = await asyncio.get_running_loop().run_in_executor(None, deliver, n.ports["satellite"].address)
            for _ in range(100):
                if n.core.links["satellite"].driver.stats["mo_delivered"]:
                    break
                await asyncio.sleep(0.01)
            return answer, n.core.links["satellite"].driver.imei

    assert asyncio.run(asyncio.wait_for(main(), 20)) == (TAKEN, IMEI)
