# The IMC gateway's protocol logic, sans-IO (docs/imc.md, "Gateway").
#
# One ImcGateway makes one acomm Node look like one DUNE system to IMC peers:
#   feed(now, endpoint, datagram)  IMC requests in (UamTxFrame, UamTxRange,
#                                  TransmissionRequest) -> acomm link requests
#   on_event(ev)                   the node's listener: acomm statuses and
#                                  receptions -> UamTxStatus / TransmissionStatus,
#                                  UamRxFrame, UamRxRange
#   announce_due(now), announce()  the Announce, every announce_ms
#   take_output()                  [(endpoint, packet bytes)]
# `now` is the IP side's clock (integer ms, ticks: ip_clock, the node's by
# default): contacts and the announce period run on it, in real time even
# when the node runs on simulated time; link requests take the node's own
# clock. wall() gives the epoch seconds that IMC headers and deadlines use. The socket loop is
# acomm_cpython.bridges.imcbridge.
#
# Every request accepted from IMC ends with exactly one final status. One
# that is refused gets its final status at once (INV_ADDR, INV_SIZE, BUSY,
# UNSUPPORTED / INV_ADDR, INPUT_FAILURE, TEMPORARY_FAILURE). Bad packets are
# counted in `stats` and otherwise ignored: IMC has no status for them.

import time

from .. import imc
from ..compat import ticks_add, ticks_diff
from ..errors import AcommError, DecodeError, CRCError, EncodeError
from ..events import (CANCELED, DELIVERED, EV_RANGE_RECEIVED, EV_RECEIVED, EV_STATUS, EXPIRED, FAILED,
                          QUEUED, TRANSMITTED, WAITING)
from ..imc import enums as E
from ..link import BROADCAST

from .imcpeers import ACOMM_NODE, ACOMM_UID, ImcPeers

IMC_BROADCAST = "broadcast"  # the sys_dst of a UamTxFrame to every node

# acomm status -> (UamTxStatus value, final) for UamTxFrame/UamTxRange, and
# TransmissionStatus status for TransmissionRequest; None: nothing to say
_UTS = {QUEUED: (E.UTS_IP, False), WAITING: (E.UTS_SENT, False), TRANSMITTED: (E.UTS_DONE, True),
        DELIVERED: (E.UTS_DELIVERED, True), EXPIRED: (E.UTS_FAILED, True), CANCELED: (E.UTS_CANCELED, True),
        FAILED: (E.UTS_FAILED, True)}
_TSTAT = {QUEUED: (E.TSTAT_IN_PROGRESS, False), TRANSMITTED: (E.TSTAT_SENT, True),
          DELIVERED: (E.TSTAT_DELIVERED, True), EXPIRED: (E.TSTAT_TEMPORARY_FAILURE, True),
          CANCELED: (E.TSTAT_PERMANENT_FAILURE, True), FAILED: (E.TSTAT_TEMPORARY_FAILURE, True)}
# TransmissionRequest.comm_mean -> the acomm link media it may use, in order
_MEANS = {E.CMEAN_ACOUSTIC: ("acoustic",), E.CMEAN_SATELLITE: ("satellite",),
          E.CMEAN_ANY: ("acoustic", "satellite")}
_KIND_UAM, _KIND_RANGE, _KIND_TREQ = 0, 1, 2
_SYNCS = (b"\x54\xfe", b"\xfe\x54")


class _Req:
    __slots__ = ("kind", "seq", "endpoint", "src", "src_ent", "said", "link")

    def __init__(self, kind, seq, endpoint, pkt):
        self.kind, self.seq, self.endpoint = kind, seq, endpoint
        self.src, self.src_ent = pkt.src, pkt.src_ent
        self.said = None  # the last status sent, so QUEUED after a retry is not repeated
        self.link = None


class ImcGateway:
    def __init__(self, node, imc_id, sys_name=None, names=None, static=(), wall=None, lifespan_s=60,
                 max_requests=32, max_output=256, announce_ms=10000, sys_type=E.SYSTEM_CCU, services=(),
                 uid=None, ip_clock=None):
        # names: {IMC system name: acomm node name} beyond those that are the
        # same on both sides and those learned from announces.
        self.node = node
        self.imc_id = imc_id
        self.names = dict(names or {})
        if sys_name is None:
            # a map entry for this node names it in IMC too
            mine = [k for k in self.names if self.names[k] == node.name]
            sys_name = mine[0] if mine else node.name
        self.sys_name = sys_name
        self.wall = wall or time.time
        self.ip_clock = ip_clock or node.clock
        self.lifespan_s = lifespan_s
        self.max_requests = max_requests
        self.max_output = max_output
        self.announce_ms = announce_ms
        self.sys_type = sys_type
        self.services = list(services)  # more URLs to announce (AnnounceService's job in DUNE)
        self.uid = uid or "%x-%x" % (int(self.wall() * 1000) & 0xFFFFFFFF, id(self) & 0xFFFF)
        self.peers = ImcPeers(imc_id, self.uid, static)
        self._reqs = {}  # acomm request id -> _Req, until its final status
        self._out = []
        self._next_announce = None
        self.stats = {"rx": 0, "bad_sync": 0, "bad_size": 0, "bad_crc": 0, "bad_payload": 0, "unknown_id": 0,
                      "not_for_us": 0, "ignored": 0, "requests": 0, "refused": 0, "statuses": 0, "published": 0,
                      "announces_sent": 0, "output_dropped": 0}

    # -- output ------------------------------------------------------------------
    def take_output(self):
        out = self._out
        self._out = []
        return out

    def _emit(self, endpoint, msg, dst=imc.enums.ADDR_NULL, dst_ent=imc.enums.ENTITY_UNKNOWN):
        if len(self._out) >= self.max_output:
            self.stats["output_dropped"] += 1  # the IO loop fell behind: the newest go
            return
        try:
            data = imc.encode(msg, self.imc_id, dst, self.wall(), 0xFF, dst_ent)
        except EncodeError:
            self.stats["output_dropped"] += 1
            return
        self._out.append((endpoint, data))

    def _publish(self, now, msg):
        self.stats["published"] += 1
        for ep in self.peers.subscribers(now):
            self._emit(ep, msg)

    # -- the Announce ---------------------------------------------------------------
    def announce(self, services=()):
        # The Announce packet: `services` (the IO layer's imc+udp URLs for
        # the variant it sends: loopback or external) and ours.
        sv = list(services) + self.services
        sv.append("%s%d/%s" % (ACOMM_NODE, self.node.node_id, self.node.name))
        sv.append(ACOMM_UID + self.uid)
        for name, link in self.node.links.items():
            if link.medium == "acoustic":
                sv.append("imc+any://acoustic/operation/" + name)
            elif link.medium == "satellite":
                sv.append("imc+any://iridium")
        msg = {"abbrev": "Announce", "sys_name": self.sys_name, "sys_type": self.sys_type, "owner": 0xFFFF,
               "services": ";".join(sv)}
        return imc.encode(msg, self.imc_id, E.ADDR_ANNOUNCE, self.wall())

    def announce_due(self, now):
        # True once every announce_ms (and at the first call): then the IO
        # layer sends announce(...) to its destinations
        if self._next_announce is None or ticks_diff(now, self._next_announce) >= 0:
            self.stats["announces_sent"] += 1
            self._next_announce = ticks_add(now, self.announce_ms)
            return True
        return False

    # -- input --------------------------------------------------------------------
    def _decode(self, data):
        st = self.stats
        st["rx"] += 1
        if bytes(data[:2]) not in _SYNCS:
            st["bad_sync"] += 1
            return None
        if len(data) >= 6:
            size = int.from_bytes(data[4:6], "little" if data[0] == 0x54 else "big")
            if size + 22 != len(data):
                st["bad_size"] += 1  # a lying size, or a cut datagram
                return None
        try:
            pkt = imc.decode(data)
        except CRCError:
            st["bad_crc"] += 1
            return None
        except DecodeError:
            st["bad_size" if len(data) < 22 else "bad_payload"] += 1
            return None
        if pkt.msg is None:
            st["unknown_id"] += 1
            return None
        return pkt

    def on_discovery(self, now, endpoint, data):
        # a datagram on the discovery port: only Announces count there
        pkt = self._decode(data)
        if pkt is None:
            return
        if pkt.msg["abbrev"] == "Announce":
            self._learn(now, pkt)
        else:
            self.stats["ignored"] += 1

    def feed(self, now, endpoint, data):
        # one datagram on our data port
        pkt = self._decode(data)
        if pkt is None:
            return
        self.peers.heard(now, endpoint)
        name = pkt.msg["abbrev"]
        if name == "Announce":
            self._learn(now, pkt)
            return
        if pkt.dst not in (self.imc_id, E.ADDR_NULL, E.ADDR_BROADCAST):
            self.stats["not_for_us"] += 1
            return
        if name == "UamTxFrame":
            self._uam_tx_frame(now, endpoint, pkt)
        elif name == "UamTxRange":
            self._uam_tx_range(now, endpoint, pkt)
        elif name == "TransmissionRequest":
            self._treq(now, endpoint, pkt)
        elif name == "AcousticSystemsQuery":
            names = [self.imc_name(n) for n in self.node.names.names() if n != self.node.name]
            self._emit(endpoint, {"abbrev": "AcousticSystems", "list": ",".join(names)}, pkt.src, pkt.src_ent)
        else:
            self.stats["ignored"] += 1

    def _learn(self, now, pkt):
        s = self.peers.on_announce(now, pkt)
        if s is not None and s.acomm is not None:
            nid, aname = s.acomm
            names = self.node.names
            if nid != self.node.node_id and names.id_of(aname) is None:
                try:
                    names.add(aname, nid)
                except AcommError:
                    pass  # the table is full: the map from the announce still resolves it

    # -- names ------------------------------------------------------------------------
    def acomm_name(self, imc_name):
        # IMC system name -> acomm node name, or None when unknown
        names = self.node.names
        n = self.names.get(imc_name)
        if n is not None and names.id_of(n) is not None:
            return n
        s = self.peers.by_name(imc_name)
        if s is not None and s.acomm is not None and names.id_of(s.acomm[1]) == s.acomm[0]:
            return s.acomm[1]
        if names.id_of(imc_name) is not None:
            return imc_name
        return None

    def imc_name(self, acomm_name):
        if acomm_name == BROADCAST:
            return IMC_BROADCAST
        if acomm_name == self.node.name:
            return self.sys_name
        for k in self.names:
            if self.names[k] == acomm_name:
                return k
        nid = self.node.names.id_of(acomm_name)
        s = self.peers.by_acomm_id(nid) if nid is not None else None
        return s.name if s is not None else acomm_name

    def _dst_id(self, imc_name):
        # -> acomm name (BROADCAST for "broadcast"), or None for an unknown
        # system or ourselves
        if imc_name == IMC_BROADCAST:
            return BROADCAST
        if imc_name == self.sys_name:
            return None
        a = self.acomm_name(imc_name)
        return None if a is None or a == self.node.name else a

    # -- requests -----------------------------------------------------------------------
    def _uam_status(self, r, value, error=""):
        self.stats["statuses"] += 1
        self._emit(r.endpoint, {"abbrev": "UamTxStatus", "seq": r.seq, "value": value, "error": error}, r.src,
                   r.src_ent)

    def _tstat(self, r, status, info="", rng=0.0):
        self.stats["statuses"] += 1
        self._emit(r.endpoint, {"abbrev": "TransmissionStatus", "req_id": r.seq, "status": status, "range": rng,
                                "info": info}, r.src, r.src_ent)

    def _refuse(self, r, code, why):
        self.stats["refused"] += 1
        if r.kind == _KIND_TREQ:
            self._tstat(r, code, why)
        else:
            self._uam_status(r, code, why)

    def _busy(self, r):
        if len(self._reqs) < self.max_requests:
            return False
        self._refuse(r, E.TSTAT_TEMPORARY_FAILURE if r.kind == _KIND_TREQ else E.UTS_BUSY,
                     "%d requests in progress" % len(self._reqs))
        return True

    def _link_for(self, media, dst, size):
        # the first link of those media that can reach dst with size bytes
        names = self.node.names
        nid = None if dst == BROADCAST else names.id_of(dst)
        for medium in media:
            for link in self.node.links.values():
                if link.medium != medium:
                    continue
                if nid is not None and not link.addressable(nid):
                    continue
                if size is None or size <= link.mtu_for(nid):
                    return link
        return None

    def _track(self, r, link):
        # -> the request id; tracked before the link's call, since a
        # refusal is reported from inside it
        rid = self.node.next_req_id()
        r.link = link
        self._reqs[rid] = r
        self.stats["requests"] += 1
        return rid

    def _submit(self, now, r, link, dst, data, lifespan, ack):
        link.request(self.node.clock(), self._track(r, link), dst, data, lifespan, 10, ack)

    def _begin(self, kind, key, ep, pkt, dst_field, inv_addr):
        # -> (request, destination id), or None when it was refused (busy,
        # or a destination we do not know, answered with inv_addr)
        m = pkt.msg
        r = _Req(kind, m[key], ep, pkt)
        if self._busy(r):
            return None
        dst = self._dst_id(m[dst_field])
        if dst is None:
            self._refuse(r, inv_addr, "unknown system %r" % m[dst_field])
            return None
        return r, dst

    def _uam_tx_frame(self, now, ep, pkt):
        got = self._begin(_KIND_UAM, "seq", ep, pkt, "sys_dst", E.UTS_INV_ADDR)
        if got is None:
            return
        r, dst = got
        m = pkt.msg
        link = self._link_for(("acoustic",), dst, None)
        if link is None:
            return self._refuse(r, E.UTS_INV_ADDR, "no acoustic link reaches %r" % m["sys_dst"])
        data = m["data"]
        mtu = link.mtu_for(None if dst == BROADCAST else self.node.names.id_of(dst))
        if len(data) > mtu or not data:
            return self._refuse(r, E.UTS_INV_SIZE, "%d bytes, the modem takes 1..%d" % (len(data), mtu))
        ack = bool(m["flags"] & E.UTF_ACK) and dst != BROADCAST
        self._submit(now, r, link, dst, data, self.lifespan_s, ack)

    def _uam_tx_range(self, now, ep, pkt):
        got = self._begin(_KIND_RANGE, "seq", ep, pkt, "sys_dst", E.UTS_INV_ADDR)
        if got is None:
            return
        r, dst = got
        m = pkt.msg
        if dst == BROADCAST:
            return self._refuse(r, E.UTS_INV_ADDR, "cannot range %r" % m["sys_dst"])
        self._range(now, r, ("acoustic",), dst, m["timeout"] if m["timeout"] > 0 else self.lifespan_s)

    def _range(self, now, r, media, dst, lifespan):
        link = self._link_for(media, dst, None)
        if link is None:
            code = E.TSTAT_TEMPORARY_FAILURE if r.kind == _KIND_TREQ else E.UTS_INV_ADDR
            return self._refuse(r, code, "no acoustic link reaches %s" % dst)
        link.range(self.node.clock(), self._track(r, link), [dst], lifespan)

    def _treq(self, now, ep, pkt):
        got = self._begin(_KIND_TREQ, "req_id", ep, pkt, "destination", E.TSTAT_INV_ADDR)
        if got is None:
            return
        r, dst = got
        m = pkt.msg
        media = _MEANS.get(m["comm_mean"])
        if media is None:
            return self._refuse(r, E.TSTAT_INPUT_FAILURE, "comm_mean %d is not served here" % m["comm_mean"])
        life = m["deadline"] - self.wall()
        if life <= 0:
            return self._refuse(r, E.TSTAT_TEMPORARY_FAILURE, "Transmission timed out")
        life = min(life, 86400.0)
        mode = m["data_mode"]
        if mode == E.DMODE_RANGE:
            if dst == BROADCAST:
                return self._refuse(r, E.TSTAT_INV_ADDR, "cannot range every node")
            return self._range(now, r, ("acoustic",), dst, life)
        try:
            if mode == E.DMODE_INLINEMSG:
                if m["msg_data"] is None:
                    return self._refuse(r, E.TSTAT_INPUT_FAILURE, "no inline message")
                data = imc.encode_inline(m["msg_data"])
            elif mode == E.DMODE_TEXT:
                data = m["txt_data"].encode()
            elif mode == E.DMODE_RAW:
                data = m["raw_data"]
            elif mode == E.DMODE_ABORT:
                data = imc.encode_inline({"abbrev": "Abort"})
            else:
                return self._refuse(r, E.TSTAT_INPUT_FAILURE, "data_mode %d is not served here" % mode)
        except EncodeError as e:
            return self._refuse(r, E.TSTAT_INPUT_FAILURE, str(e))
        if not data:
            return self._refuse(r, E.TSTAT_INPUT_FAILURE, "nothing to send")
        link = self._link_for(media, dst, len(data))
        if link is None:
            return self._refuse(r, E.TSTAT_TEMPORARY_FAILURE,
                                "No communication mode available for this destination/message type")
        # the satellite link's own acks would cost a second message each way
        self._submit(now, r, link, dst, data, life, dst != BROADCAST and link.medium == "acoustic")

    # -- acomm events -------------------------------------------------------------------
    def on_event(self, ev):
        code = ev[0]
        if code == EV_STATUS:
            self._on_status(ev[2], ev[3], ev[4])
        elif code == EV_RECEIVED:
            self._on_received(ev[1], ev[2], ev[3], ev[4])
        elif code == EV_RANGE_RECEIVED:
            self._on_range(ev[2], ev[3], ev[4])

    def _on_status(self, rid, status, reason):
        r = self._reqs.get(rid)
        if r is None:
            return  # not ours (an application on the same node)
        table = _TSTAT if r.kind == _KIND_TREQ else _UTS
        t = table.get(status)
        if t is None:
            return
        value, final = t
        if final:
            del self._reqs[rid]
            if r.kind == _KIND_RANGE and status == DELIVERED:
                value = E.UTS_DONE  # the range went out as UamRxRange
        elif value == r.said:
            return
        r.said = value
        if status == EXPIRED and not reason:
            reason = "Transmission timed out"
        if r.kind == _KIND_TREQ:
            self._tstat(r, value, reason)
        else:
            self._uam_status(r, value, reason)

    def _on_range(self, rid, names, metres):
        r = self._reqs.get(rid)
        if r is None or not metres or metres[0] is None:
            return  # a failed ping ends with FAILED from the link
        if r.kind == _KIND_TREQ:
            del self._reqs[rid]  # the link's DELIVERED that follows is swallowed
            self._tstat(r, E.TSTAT_RANGE_RECEIVED, "", float(metres[0]))
        else:
            msg = {"abbrev": "UamRxRange", "seq": r.seq, "sys": self.imc_name(names[0]), "value": float(metres[0])}
            self._emit(r.endpoint, msg, r.src, r.src_ent)

    def _on_received(self, link, src, dst, data):
        flags = 0 if dst in (BROADCAST, self.node.name) else E.URF_PROMISCUOUS
        msg = {"abbrev": "UamRxFrame", "sys_src": self.imc_name(src), "sys_dst": self.imc_name(dst),
               "flags": flags, "data": bytes(data)}
        self._publish(self.ip_clock(), msg)
