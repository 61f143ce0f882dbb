# How a link puts acomm frames on its interface, and takes them off.
#
# raw     the interface has no addressing or integrity (serial radio, UDP):
#         the acomm raw header carries node ids and the frame ends with a CRC.
# elided  the modem addresses and checks frames itself (Seatrac, EvoLogics,
#         Micro-Modem): one header byte, and node ids are translated to and
#         from modem addresses through the link's AddressMap.
#
# The link above deals only in node ids (None meaning broadcast).
#
# fec > 0 appends that many Reed-Solomon parity bytes (acomm.codec.fec) to every
# frame, so a receiver repairs up to fec // 2 damaged bytes instead of
# losing the frame. It helps where damaged frames reach the host: serial
# radios and the software-defined packet modems of seed 004 (raw frames,
# whose CRC then checks the repair). Modems that check frames themselves
# drop damaged ones before acomm sees them. A codeword is at most 255
# bytes, so the frame's MTU shrinks to 255 - fec when it was larger. Both
# ends of a link must use the same fec.
#
# With an acomm.frame.auth.Auth (set_auth; the node gives every link the same
# one), each frame is sealed with a counter and a tag (F_AUTH set, which on
# an elided link costs the flags byte), and a received frame that carries
# F_AUTH is opened: a wrong tag or a replayed counter raises AuthError, and
# a frame that verifies is marked authed. Frames without F_AUTH pass as
# they are, unauthenticated: what may not be done on their word is decided
# above (acomm.link.guard).

from .. import frame as fr
from ..errors import AuthError, DecodeError


class LinkFraming:
    # Defaults for what most links never set (no FEC, no key): on MicroPython
    # an instance's attribute table grows in steps (12, 17, 23, ... slots of
    # 8 bytes), and ten attributes take 80 bytes where thirteen took 136
    _rs = None
    auth = None
    corrected = 0  # bytes repaired by the FEC

    def __init__(self, node_id, elided, addr_map, mtu, link_acks=False, fec=0):
        self.node_id = node_id
        self.elided = elided
        self.link_acks = link_acks
        self.addr_map = addr_map
        self.seq_mod = fr.SEQ_MOD_ELIDED if elided else fr.SEQ_MOD_RAW
        if elided:
            self.worst_overhead = fr.ELIDED_OVERHEAD + (1 if link_acks else 0)
        else:
            # to any one-byte id (a peer of 256 or more costs 2 bytes more:
            # mtu_for is exact per peer, and the transport sizes by it)
            self.worst_overhead = fr.raw_overhead(node_id, 254)
        if fec:
            from ..codec.fec import ReedSolomon

            self._rs = ReedSolomon(fec)
            self.worst_overhead += fec
            mtu = min(mtu, 255)
        self.fec = fec
        self._mtu = mtu
        self._buf = bytearray(mtu + fr.RAW_OVERHEAD_MAX)
        self._plain_overhead = self.worst_overhead

    def set_auth(self, auth):
        self.auth = auth
        self.worst_overhead = self._plain_overhead
        if auth is not None:
            # the counter and tag, and on an elided link the flags byte
            self.worst_overhead += auth.overhead + (0 if (not self.elided or self.link_acks) else 1)

    def mtu_for(self, dst_id):
        # payload bytes one frame to dst_id can carry
        if self.elided:
            return self._mtu - self.worst_overhead
        a = 0 if self.auth is None else self.auth.overhead
        return self._mtu - self.fec - a - fr.raw_overhead(self.node_id, fr.BROADCAST if dst_id is None else dst_id)

    def encode(self, ftype, dst_id, seq, payload, flags=0, again=0):
        # -> (interface address or None, frame bytes). On an elided link
        # whose modem acknowledges, the modem is asked for what the flags
        # mean and they stay off the air. again: the counter a resent frame
        # was sealed with (auth.last after its first encode), or for an ACK
        # the counter of the frame it acknowledges (0: that frame was not
        # sealed, and neither is its ACK)
        buf = self._buf
        a = self.auth
        if a is not None and ftype == fr.ACK:
            # no counter of its own: a tag bound to the acknowledged frame's
            payload = a.ack_tag(self.node_id, dst_id, seq, again) if again else None
            if payload is not None:
                flags |= fr.F_AUTH
            else:
                payload = b""
        elif a is not None:
            # adverts carry the sender's counter epoch (acomm.frame.auth), and so
            # do the first frames of a new one when they have room for it
            ann = ftype == fr.ADVERT or (a.announcing() and len(payload) + 7 <= self.mtu_for(dst_id))
            payload = a.seal(ftype, self.node_id, dst_id, payload, seq, ann, again)
            flags |= fr.F_AUTH
        if self.elided:
            n = fr.encode_elided_into(buf, ftype, seq, payload, flags if self.link_acks else flags & fr.F_AUTH)
            addr = self.addr_map.broadcast if dst_id is None else self.addr_map.addr_of(dst_id)
        else:
            d = fr.BROADCAST if dst_id is None else dst_id
            n = fr.encode_raw_into(buf, ftype, self.node_id, d, seq, payload, flags)
            addr = None
        if self._rs is not None:
            return addr, self._rs.encode(memoryview(buf)[:n])
        return addr, bytes(memoryview(buf)[:n])

    def decode(self, src_addr, dst_addr, data):
        # -> (Frame, source node id, destination node id or None for
        # broadcast). Raises DecodeError.
        if self._rs is not None:
            if len(data) <= self.fec:
                raise DecodeError("frame shorter than its FEC parity")
            data, n = self._rs.decode_count(data)
            self.corrected += n
        if not self.elided:
            f = fr.decode_raw(data)
            src, dst = f.src, (None if f.dst == fr.BROADCAST else f.dst)
        else:
            am = self.addr_map
            src = am.id_of(src_addr)
            dst = None if (dst_addr is None or dst_addr == am.broadcast) else am.id_of(dst_addr)
            f = fr.decode_elided(data, src, dst)
            if src is None:
                raise DecodeError("frame from unmapped address %r" % (src_addr,))
        if f.flags & fr.F_AUTH:
            if self.auth is None:
                raise AuthError("authenticated frame, and this node has no key")
            if f.ftype == fr.ACK:
                # its tag is bound to the counter of the frame it acknowledges:
                # the link, which knows that frame, checks it
                return f, src, dst
            # a modem reply is sealed before anyone asks for it (Link.set_reply):
            # its tag covers the broadcast destination, whoever receives it.
            # A payload of None: a genuine copy of a frame accepted before,
            # which asks for an acknowledgement (acomm.frame.auth.Auth.open)
            f.payload, f.ctr = self.auth.open(f.ftype, src, None if f.ftype == fr.REPLY else dst, f.payload,
                                              f.seq, f.flags & fr.F_ACK_REQ and dst is not None)
            f.authed = True
        return f, src, dst
