# `acomm bridge imc --sim` as a child process on loopback, spoken to by plain
# UDP sockets as an IMC tool would: a UamTxFrame to the near system comes
# back as UamTxStatus (in progress, then delivered) and comes out of the far
# system as UamRxFrame; bad datagrams and a flood are counted and the
# gateway keeps answering; its Announce arrives on the multicast group and
# on the loopback.
import json
import os
import socket
import struct
import subprocess
import sys
import time

from acomm import imc
from acomm.imc import enums as E

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GROUP = "224.0.75.69"
ANNOUNCE_PORTS = (30100, 30101, 30102, 30103, 30104)
ME = 0x4444  # the test's IMC id


def _bridge(*args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
    cmd = [sys.executable, "-m", "acomm_cpython.cli", "bridge", "imc", "--host", "127.0.0.1", "--iface", "127.0.0.1",
           "--port", "0"] + list(args)
    p = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                         text=True)
    line = p.stdout.readline()
    if not line:
        p.kill()
        raise AssertionError(p.stderr.read())
    return p, json.loads(line)


def _finish(p):
    p.terminate()  # the bridge prints its counters and ends on SIGTERM
    out, err = p.communicate(timeout=20)
    assert p.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


def _udp():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.2)
    return s


def _collect(s, until, seconds):
    # packets from s until until(list) is true or the time is up
    got = []
    end = time.monotonic() + seconds
    while time.monotonic() < end and not until(got):
        try:
            data, src = s.recvfrom(65535)
        except socket.timeout:
            continue
        got.append((src, imc.decode(data)))
    return got


def _tx_frame(seq, dst, data, imc_dst):
    msg = {"abbrev": "UamTxFrame", "seq": seq, "sys_dst": dst, "flags": E.UTF_ACK, "data": data}
    return imc.encode(msg, src=ME, dst=imc_dst, timestamp=time.time())


def test_uam_tx_frame_through_the_simulated_network_and_bad_input():
    p, info = _bridge("--sim", "--speed", "20", "--seconds", "20")
    s = _udp()
    try:
        top, auv = info["systems"]
        assert (top["name"], auv["name"]) == ("topside", "auv")
        top_ep, auv_ep = ("127.0.0.1", top["port"]), ("127.0.0.1", auv["port"])
        # anything from us makes us a contact of the far system: it then
        # sends us what it publishes, as DUNE's UDP transport does
        s.sendto(imc.encode({"abbrev": "Heartbeat"}, src=ME, dst=auv["imc_id"], timestamp=time.time()), auv_ep)
        # bad input first: none of it may stop the gateway or get an answer
        good = _tx_frame(1, "auv", b"x", top["imc_id"])
        bad_crc = good[:-1] + bytes([good[-1] ^ 0xFF])
        lying = good[:4] + struct.pack("<H", 200) + good[6:]
        unknown = imc.Packet(None, ME, top["imc_id"], 0.0, mgid=999, payload=b"\x01\x02").encode()
        for junk in (b"\x00\x01garbage", bad_crc, lying, unknown, b"\x54"):
            s.sendto(junk, top_ep)
        for i in range(300):  # a flood of bad packets
            s.sendto(bad_crc, top_ep)
        # what overflows the socket buffer the kernel drops, requests too
        # (UDP): ask with a request it must refuse until the refusal comes
        # back, so the flood is drained before the real request goes
        def refused8(got):
            return [m.msg for _, m in got if m.msg["abbrev"] == "UamTxStatus" and m.msg["seq"] == 8]

        st8 = []
        for _ in range(50):
            s.sendto(_tx_frame(8, "nobody", b"x", top["imc_id"]), top_ep)
            st8 = refused8(_collect(s, refused8, 0.2))
            if st8:
                break
        s.sendto(_tx_frame(7, "auv", b"hello auv", top["imc_id"]), top_ep)

        def done(got):
            st = [m.msg for _, m in got if m.msg["abbrev"] == "UamTxStatus" and m.msg["seq"] == 7]
            rx = [m for _, m in got if m.msg["abbrev"] == "UamRxFrame"]
            return rx and st and st[-1]["value"] == E.UTS_DELIVERED

        got = _collect(s, done, 5)
        names = [(src[1], m.msg["abbrev"]) for src, m in got]
        st7 = [m for src, m in got if m.msg["abbrev"] == "UamTxStatus" and m.msg["seq"] == 7]
        st8 += [m.msg for src, m in got if m.msg["abbrev"] == "UamTxStatus" and m.msg["seq"] == 8]
        rx = [(src, m) for src, m in got if m.msg["abbrev"] == "UamRxFrame"]
        assert st8 and all(m["value"] == E.UTS_INV_ADDR for m in st8), names
        values = [m.msg["value"] for m in st7]
        assert values[0] == E.UTS_IP and values[-1] == E.UTS_DELIVERED, values
        assert all(v in (E.UTS_IP, E.UTS_SENT) for v in values[:-1]), values
        for m in st7:
            assert (m.src, m.dst) == (top["imc_id"], ME)
        assert len(rx) == 1, names
        src, m = rx[0]
        assert src == auv_ep and m.src == auv["imc_id"]
        assert m.msg == {"abbrev": "UamRxFrame", "sys_src": "topside", "sys_dst": "auv", "flags": 0,
                         "data": b"hello auv"}
    finally:
        s.close()
        report = _finish(p)
    c = report["systems"]["topside"]
    assert c["bad_sync"] == 2 and c["bad_size"] == 1 and c["unknown_id"] == 1, c
    assert c["bad_crc"] >= 100, c  # the kernel may drop part of the flood
    assert c["requests"] == 1 and c["refused"] >= len(st8) >= 1, c


def _listener(port, multicast):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    s.bind((GROUP if multicast else "127.0.0.1", port))
    if multicast:
        s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, socket.inet_aton(GROUP) + socket.inet_aton("127.0.0.1"))
    s.settimeout(0.2)
    return s


def test_announce_on_the_multicast_group_and_the_loopback():
    p, info = _bridge("--sim", "--sim-node", "buoy=3", "--announce-period", "0.5", "--seconds", "20")
    socks = []
    try:
        sysinfo = info["systems"][0]
        port = [x for x in ANNOUNCE_PORTS if x != info["discovery_port"]][0]
        loop = _listener(port, False)
        socks.append(loop)
        mcast = None
        try:
            mcast = _listener(port, True)
            socks.append(mcast)
        except OSError:
            assert not info["multicast"], "the gateway joined the group where the test cannot"
        want = "imc+udp://127.0.0.1:%d/" % sysinfo["port"]
        for s in socks:
            # two of them, sent at different times: the Announce is
            # periodic (every 0.5 s here)
            got = _collect(s, lambda g: len(set(x[1].timestamp for x in g)) >= 2, 5)
            assert len(set(x[1].timestamp for x in got)) >= 2, "%d Announces on %s" % (len(got), s.getsockname())
            src, pkt = got[0]
            m = pkt.msg
            assert m["abbrev"] == "Announce" and m["sys_name"] == "buoy", m
            assert (pkt.src, pkt.dst) == (sysinfo["imc_id"], 0)
            assert src == ("127.0.0.1", sysinfo["port"])
            assert want in m["services"].split(";") and "acomm://node/3/buoy" in m["services"], m["services"]
        if info["multicast"]:
            assert mcast is not None
    finally:
        for s in socks:
            s.close()
        report = _finish(p)
    assert report["bridge"]["announce_loopback"] >= 2  # as many as the loopback listener heard, at least


def test_real_modem_path_against_an_emulated_seatrac_on_a_pty(tmp_path):
    # the CPython port's serial stream and the real SeaTrac driver, with
    # `acomm emulate` as the modem and a headless beacon 2 in its water
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
    link = str(tmp_path / "beacon1")
    emu = subprocess.Popen([sys.executable, "-m", "acomm_cpython.cli", "emulate", "seatrac", "--link", link,
                            "--address", "1", "--peer", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           env=env, text=True)
    p = None
    s = _udp()
    try:
        emu.stdout.readline()
        p, info = _bridge("--name", "topside", "--id", "1", "--known", "auv=2", "--modem", "seatrac:" + link,
                          "--no-multicast", "--broadcast", "none", "--seconds", "20")
        top = info["systems"][0]
        s.sendto(_tx_frame(4, "auv", b"ping", top["imc_id"]), ("127.0.0.1", top["port"]))
        got = _collect(s, lambda g: g and g[-1][1].msg["value"] in (E.UTS_DELIVERED, E.UTS_FAILED), 6)
        assert [m.msg["value"] for _, m in got] == [E.UTS_IP, E.UTS_SENT, E.UTS_DELIVERED], [m.msg for _, m in got]
    finally:
        s.close()
        if p is not None:
            _finish(p)
        emu.terminate()
        emu.communicate(timeout=10)
