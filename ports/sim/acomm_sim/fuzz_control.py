# Fuzz target "control": the sealed control plane (acomm.link.guard's strict
# mode) under arbitrary frames. A node with the key, a link on an elided
# modem that leaves acknowledgements to acomm, and a Transport, with an
# acknowledged frame and a transport packet waiting for node 2; an input is
# 1..4 frames, each (source address, destination address, length, bytes),
# handed over as the modem would, then the node steps. The corpus holds
# frames a peer with the key seals (ACKs, adverts, SACKs, fragments, data)
# and the same without a tag.
#
# Oracle, beyond "only acomm errors": unless some frame verified, the
# acknowledged frame is not delivered, the packet neither delivered nor
# failed, and the address map unchanged; the transport holds at most its 8
# reassemblies and the link queue stays within its capacity.

from acomm import frame as fr
from acomm.transport import segment as sg
from acomm.apps.policy import commands
from acomm.frame.auth import Auth
from acomm.drivers.base import SansIO
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST, Capabilities
from acomm.events import DELIVERED, EV_PACKET_STATUS, EV_STATUS, FAILED
from acomm.link.framing import LinkFraming
from acomm.link.names import AddressMap
from acomm.node import Node
from acomm.prng import Prng
from acomm.transport import Transport

from .fuzz_base import Failure, Target

KEY = b"fuzzing the control plane, 32 b"


class _Modem(SansIO):
    # an elided modem without its own acks: what the link sends is kept
    def __init__(self):
        SansIO.__init__(self)
        self.caps = Capabilities("fuzz", "modem", mtu_tx=31, mtu_rx=31, bitrate=100, latency_ms=1000,
                                 flags=CAP_ADDRESSING | CAP_BROADCAST)
        self.broadcast_addr = 0
        self._h = 0

    def ready(self, now):
        return True

    def send(self, now, addr, data, ack=False):
        self._h += 1
        from acomm.events import EV_TX_DONE

        self._events.append((EV_TX_DONE, self._h))
        return self._h

    def feed(self, now, data):
        pass

    def poll(self, now):
        pass



def _corpus():
    rng = Prng(211)
    peer = LinkFraming(2, True, AddressMap(True, 0), 31, True)
    peer.set_auth(Auth(KEY))
    frames = []
    for i in range(24):
        kind = i % 6
        if kind == 0:
            ftype, seq, body = fr.ACK, rng.below(16), b""
        elif kind == 1:
            ftype, seq, body = fr.ADVERT, rng.below(16), bytes((rng.below(4), 1 + rng.below(30)))
        elif kind == 2:
            seq, body = sg.sack_complete(rng.below(2), rng.below(2), 1 + rng.below(3), rng.below(4))
            ftype = fr.SEGMENT
        elif kind == 3:
            seq, body = sg.sack(rng.below(2), rng.below(2), rng.below(4), rng.bytes(rng.below(3)))
            ftype = fr.SEGMENT
        elif kind == 4:
            seq, first = sg.frag_header(rng.chance(0.5), rng.below(2), rng.below(2), 0)
            body = first + sg.packet_header(rng.below(9), 5) + rng.bytes(5)
            ftype = fr.SEGMENT
        else:
            ftype, seq, body = fr.DATA, rng.below(16), rng.bytes(1 + rng.below(8))
        dst = None if ftype == fr.ADVERT else 1
        sealed = peer.encode(ftype, dst, seq, body)[1]
        plain = fr.encode_elided(fr.Frame(ftype, 0, 0, seq, body))
        for data in (sealed, plain):
            frames.append(bytes((2, 0 if dst is None else 1, len(data))) + data)
    out = []
    for i in range(32):
        n = 1 + rng.below(3)
        out.append(b"".join(frames[rng.below(len(frames))] for _ in range(n)))
    return out


def _node():
    events = []
    node = Node("me", 1, lambda: 0, listener=events.append)
    node.names.add("peer", 2)
    node.set_auth(Auth(KEY), commands())
    link = node.add_link("acoustic", _Modem(), advert_period_ms=600000, queue_capacity=8)
    Transport.of(node, wall=lambda: 1000)
    return node, link, events


def _frames(data):
    o = 0
    while o + 3 <= len(data) and o < 4 * 64:
        n = data[o + 2]
        yield data[o], data[o + 1], data[o + 3 : o + 3 + n]
        o += 3 + n


def target():
    def run(data, rng):
        node, link, events = _node()
        node.send("acoustic", "peer", b"waiting", 60, ack=True, now=0)
        pid = node.transport.send(0, "peer", b"a packet", 600)
        node.step(0)
        node.step(10)
        auth = node.auth
        now = 20
        for i, (src, dst, frame) in enumerate(_frames(data)):
            if i >= 4:
                break
            link._on_rx(now, src, dst, frame)
            now += 500
            node.step(now)
        verified = auth.stats["opened"] > 0
        t = node.transport
        if len(t._rx) > 8 or len(link.queue) > 8:
            raise Failure("bounds: %d reassemblies, %d queued" % (len(t._rx), len(link.queue)))
        if verified:
            return
        for ev in events:
            if ev[0] == EV_STATUS and ev[3] == DELIVERED:
                raise Failure("an acknowledged frame delivered on unsealed frames")
            if ev[0] == EV_PACKET_STATUS and ev[1] == pid and ev[2] in (DELIVERED, FAILED):
                raise Failure("the packet %s on unsealed frames" % ("delivered" if ev[2] == DELIVERED else "failed"))
        if link.addr_map.addr_of(2) != 2 or link.addr_map.addr_of(1) != 1:
            raise Failure("the address map moved on unsealed frames")

    return Target("control", _corpus(), run)


def file_target(tmpdir):
    # Target "auth.file": the counter file (acomm.frame.auth) as power cuts and
    # flash rot leave it. Corpus: files Auth wrote (derived and dropped key
    # phases, sources with epochs, ids of 256 and more among them). Oracle,
    # beyond "only acomm errors": the node starts whatever the file holds (a
    # damaged one means a new epoch), and then seals a frame that a peer
    # holding its key phases opens.
    import os

    from acomm.frame.auth import OP_DROP, OP_INSTALL, OP_USE, key_command

    path = (tmpdir or "/tmp") + "/acomm-fuzz-auth-file"  # as fuzz_store does without a folder
    rng = Prng(307)
    corpus = []
    for i in range(12):
        for p in (path, path + ".new"):
            try:
                os.remove(p)
            except OSError:
                pass
        a = Auth(KEY, path=path, reserve=4, wall=lambda: 1000 + i)
        peer = Auth(KEY)
        nonce = rng.bytes(8)
        for x in (a, peer):
            if i % 3:
                x.key_command(key_command(OP_INSTALL, 1, nonce))
            if i % 3 == 2:
                x.key_command(key_command(OP_USE, 1))
        if i % 3 == 2:
            a.key_command(key_command(OP_DROP, 0))
        for k in range(rng.below(5)):
            # one-byte sources, and ids of 256 and more (their section of the file) in half the files
            src = 2 + rng.below(20) if i % 2 or rng.chance(0.5) else 256 + rng.below(65279)
            peer.epoch = rng.below(1 << 31)
            a.open(fr.ADVERT, src, None, peer.seal(fr.ADVERT, src, None, b"\x02\x01", 0, True))
        a.commit()
        for _ in range(rng.below(9)):
            a.seal(fr.DATA, 1, 2, b"x")
        with open(path, "rb") as f:
            corpus.append(f.read())

    def run(data, rng):
        for p in (path, path + ".new"):
            try:
                os.remove(p)
            except OSError:
                pass
        with open(path if rng.chance(0.8) else path + ".new", "wb") as f:
            f.write(data)
        a = Auth(KEY, path=path, wall=lambda: 5000)
        if a._keys[a.phase] is None:
            if a.phase != 1 or a._nonces[1] is not None:
                raise Failure("started with no key for the phase in use")
            return  # an add_key() key: the port adds it again at start
        body = a.seal(fr.DATA, 1, 2, b"after the start", 3, True)
        peer = Auth(KEY)
        if a._nonces[1] is not None:
            peer.key_command(key_command(OP_INSTALL, 1, a._nonces[1]))
        if peer.open(fr.DATA, 1, 2, body, 3)[0] != b"after the start":
            raise Failure("a frame sealed after the start does not open")

    return Target("auth.file", corpus, run)
