# The attacker's side of `acomm bench attack` (attack_workload): what it
# answers to what it hears, and its own schedule. A mixin of the bench's
# Attack, whose attributes it uses: eve (acomm_sim.attacker.Attacker), rng,
# tries and won (per kind), recorded and before_restart (sealed frames
# heard), cmd_recorded (every copy of a command heard, with its time),
# restart_ms and jump_ms, jumped, pids, forged and sealed_tries (what it sent, for
# the spies), out (packets waiting for the channel), restarted, sn (the nodes); for the
# route attacks route_rng, route_recorded and route_before_restart (sealed
# route control heard), route_tries and forged_requests (what it sent).
from acomm import frame as fr
from acomm.compat import ticks_diff
from acomm.transport import routing as W
from acomm.transport.flood import encode_flood
from acomm.transport import segment as sg
from acomm.catalog import teleop
from acomm.codec.compress import compress
from acomm.drivers import seatrac_codes as sc

from ...demo.places import ADDR, AUV, BUOY, DIVER

# acomm.transport.routing's route fields (a route is a list: next hop, link, cost, seq, expires, valid, used)
NEXT, SEQ, EXPIRES, VALID = 0, 3, 4, 5

NAMES = (BUOY, DIVER, AUV)
EVE = 14  # the attacker's own beacon id
ROUTE_HOPS = tuple(range(5, 14))  # made-up neighbours forged route requests come from
ROUTE_ORIGINS = tuple(range(20, 60))  # made-up origins of forged route requests


def unsealed(payload):
    # a sealed frame's payload -> the message, without its counter and tag (and, in the first
    # frames of an epoch, the counter and epoch announced in the clear before them)
    n = 14 if len(payload) >= 14 and payload[-7:-4] == b"\0\0\0" else 7
    return payload[:-n]


def _split(data):
    # an elided frame heard on the water -> (type, seq, flags, payload without counter and tag)
    if not data:
        return None
    try:
        f = fr.decode_elided(data, 0, 0)
    except Exception:
        return None
    body = f.payload[:-7] if f.flags & fr.F_AUTH else f.payload
    return f.ftype, f.seq, f.flags, body


class Forger:
    # -- the attacker ---------------------------------------------------------------------
    def _heard(self, t, p):
        if p.src not in ADDR.values() or p.src == p.dst:
            return
        f = _split(p.data)
        if f is None:
            return
        ftype, seq, flags, body = f
        if flags & fr.F_AUTH:
            # route control apart, for route_replay: the other replays keep their own mix
            rec = self.route_recorded if ftype == fr.CONTROL else self.recorded
            rec.append((p.src, p.dst, p.data))
            if len(rec) > 40:
                rec.pop(0)
        if ftype == fr.DATA and p.mtype in (sc.MSG_REQ, sc.MSG_REQU, sc.MSG_REQX):
            # after the beacon's own reply would have ended (not to jam it:
            # a jammer needs no key), before the asker gives up on it
            self._forge(t + 1200, p.dst, p.src, fr.encode_elided(fr.Frame(fr.ACK, 0, 0, seq)), "ack")
        elif ftype == fr.SEGMENT and not seq & 8 and body:
            lane, gen = 1 if seq & 2 else 0, seq & 1
            key = (p.src, p.dst, lane)
            if body[0] == 0 and len(body) > 5:
                try:
                    h = sg.decode_packet_header(body[1:])
                    size = len(body) - 1
                    total = h.size + h.length
                    self.pids[key] = (h.pid, 1 if total <= size else (total + size - 1) // size)
                except Exception:
                    pass
            if not seq & 4:
                return  # the SACK the sender waits for answers a poll
            turn = self.sack_turn % 3
            self.sack_turn += 1
            if turn == 0 and key in self.pids:
                pid, count = self.pids[key]
                head, data = sg.sack_complete(lane, gen, count, pid)
                kind = "sack_complete"
            elif turn == 1:
                head, data = sg.sack(lane, gen, (body[0] + 1) & 0xFF, b"\xff" * 8)
                kind = "sack_bitmap"
            else:
                head, data = sg.sack_refused(lane, gen, sg.REFUSE_TOO_BIG)
                kind = "sack_refusal"
            self.forged[(head, data)] = kind
            self._forge(t + 100, p.dst, p.src, fr.encode_elided(fr.Frame(fr.SEGMENT, 0, 0, head, data)), kind)

    def _forge(self, when, src, dst, data, kind):
        self.out.append([when, src, dst, data, kind])

    def attack(self, now):
        # the attacker's own schedule; what it heard is answered in _flush
        r = self.rng
        minute = now // 60000
        victim = ADDR[NAMES[minute % 3]]
        if self._m != minute and now % 60000 >= self._offset:
            self._m = minute
            self._offset = r.below(40000)  # when in the next minute: not in step with the TDMA cycle
            # an advert claiming a node's id, from the attacker's beacon
            claim = ADDR[NAMES[(minute + 1) % 3]]
            self._forge(now, EVE, sc.BEACON_ALL, fr.encode_elided(fr.Frame(fr.ADVERT, 0, 0, minute % 16,
                                                                           bytes((claim, 15)))), "advert")
            # replays of sealed frames heard: to the same node, and to another
            for src, dst, data in self.recorded[-3:]:
                again = bytearray(data)
                again[0] = (again[0] & 0xF0) | ((again[0] + 5) & 0x0F)
                self._forge(now + 500, src, dst, bytes(again), "replay_same")
                self._forge(now + 500, src, dst, data, "replay_same")
                if dst != sc.BEACON_ALL:  # a broadcast is for the other node too
                    other = [a for a in ADDR.values() if a not in (src, dst)][0]
                    self._forge(now + 1000, src, other, data, "replay_other")
            if self.restarted:
                for src, dst, data in self.before_restart[minute % 4 * 3:minute % 4 * 3 + 3]:
                    self._forge(now + 1500, src, dst, data, "replay_restart")
            # every copy of the commands heard in the 3 minutes before the AUV's restart (or its
            # clock's jump), each minute for 3 minutes after it: a copy the AUV never took is
            # inside its counter window for as long as the buoy sends fewer than 32 frames
            for kind, at, done in (("replay_after_restart", self.restart_ms, self.restarted),
                                   ("replay_after_clock_jump", self.jump_ms, self.jumped)):
                if done and now - at < 180000:
                    for when, src, dst, data in self.cmd_recorded:
                        if at - 180000 <= when < at:
                            self._forge(now + 1700, src, dst, data, kind)
            # tag guessing: a thrust command from the buoy, counter and tag made up
            cmd = teleop.CATALOG.pack([(teleop.THRUST, teleop.thrust_values((1, 1, 0, 0, 0, 0), 0))])
            for k in range(3):
                self._forge(now + 2000 + 100 * k, ADDR[BUOY], ADDR[AUV],
                            fr.encode_elided(fr.Frame(fr.DATA, 0, 0, r.below(16), cmd + r.bytes(7), fr.F_AUTH)),
                            "tag_guess")
            # a flood of fragment 0s from made-up sources, both lanes
            for k in range(6):
                src = 5 + r.below(9)
                lane = r.below(2)
                h, first = sg.frag_header(False, lane, r.below(2), 0)
                self._forge(now + 3000 + 100 * k, src, victim, fr.encode_elided(fr.Frame(
                    fr.SEGMENT, 0, 0, h, first + sg.packet_header(r.below(65536), 60) + r.bytes(10))), "flood")
            # oversized length, and a decompression bomb
            h, first = sg.frag_header(True, 0, 0, 0)
            self._forge(now + 4000, 5 + r.below(9), victim, fr.encode_elided(fr.Frame(
                fr.SEGMENT, 0, 0, h, first + sg.packet_header(1, sg.MAX_LENGTH) + bytes(10))), "oversize")
            v = (1 << 20) << 2 | 2
            bomb = bytes((v & 0x7F | 0x80, (v >> 7) & 0x7F | 0x80, (v >> 14) & 0x7F | 0x80, v >> 21))
            bomb += compress(bytes(100))[2:]
            self._forge(now + 4500, 5 + r.below(9), victim, fr.encode_elided(fr.Frame(
                fr.SEGMENT, 0, 0, h, first + sg.packet_header(2, len(bomb), True) + bomb)), "oversize")
            self._route_attacks(now + 5000, minute)
        self._flush(now)

    def _control(self, when, src, dst, payload, kind, seal=False):
        # a forged route control frame, unsealed or with F_AUTH and a made-up counter and tag
        r = self.route_rng
        if seal:
            data = fr.encode_elided(fr.Frame(fr.CONTROL, 0, 0, r.below(16), payload + r.bytes(7), fr.F_AUTH))
        else:
            data = fr.encode_elided(fr.Frame(fr.CONTROL, 0, 0, r.below(16), payload))
        self._forge(when, src, dst, data, kind)

    def _route_attacks(self, at, minute):
        # route poisoning and amplification (issue 36), one kind a minute in turn (the attacker's
        # air is already busy most of each minute: more would leave it no time to hear, and the
        # forged ACKs and SACKs answer what it hears), unsealed, or with F_AUTH and a made-up
        # counter and tag, by turns. The attacker is told the nodes' route tables: more than it
        # needs, since a seal does not hide a payload and it hears the requests and replies that
        # made them. Its own random numbers: the other attacks draw what they drew before routing
        r = self.route_rng
        kind = minute % 5
        seal = minute // 5 % 2 == 1
        if kind == 0:
            # forged replies: a route to another node, fresher and cheaper than any, via the
            # attacker's beacon, or via the third node (a route that the forgery moves); that one,
            # when the victim knows a number, as a shortcut (hops 1, the number it holds, which a
            # node that overhears the long way offers: taken when cheaper)
            for k in range(2):
                victim = NAMES[(minute // 5 + k) % 3]
                others = [n for n in NAMES if n != victim]
                dest = others[r.below(2)]
                via = EVE if k == 0 else ADDR[[n for n in others if n != dest][0]]
                e = self.table(victim).routes.get(ADDR[dest])
                known = -1 if e is None else e[SEQ]  # the newest number the victim knows, or -1
                seq = (known + 1 + r.below(1000)) % W.UNKNOWN_SEQ if known >= 0 else r.range(1, 30000)
                cut = k == 1 and known >= 0
                payload = W.encode_reply(ADDR[dest], known if cut else seq, ADDR[victim], 1 if cut else 0, 0,
                                         255 * W.LIFETIME_UNIT_MS)
                self._control(at + 300 * k, via, ADDR[victim], payload, "route_reply", seal)
        elif kind == 1:
            # forged errors from a live route's next hop, naming its destination, number raised
            live = []
            now = at - 5000
            for name in NAMES:
                t = self.table(name)
                for d in sorted(t.routes):
                    e = t.routes[d]
                    if e[VALID] and ticks_diff(e[EXPIRES], now) > 0 and e[NEXT] in ADDR.values():
                        live.append((name, d, e[NEXT], e[SEQ]))
            for k in range(3):
                if live:
                    victim, dest, hop, seq = live[r.below(len(live))]
                else:  # none: a guess
                    victim = NAMES[(minute // 5 + k) % 3]
                    dest = hop = ADDR[[n for n in NAMES if n != victim][r.below(2)]]
                    seq = -1
                seq = (seq + 1 + r.below(100)) % W.UNKNOWN_SEQ if seq >= 0 else r.below(30000)
                dst = ADDR[victim] if k == 0 else sc.BEACON_ALL  # errors go to all; one to the node
                self._control(at + 300 * k, hop, dst, W.encode_error([(dest, seq)]), "route_error", seal)
        elif kind == 2:
            # forged requests from made-up origins by made-up neighbours, for a made-up node
            # (every node would pass it on) and for a real one (which would answer)
            for k in range(2):
                origin = ROUTE_ORIGINS[r.below(len(ROUTE_ORIGINS))]
                rid = r.below(256)
                dest = ROUTE_ORIGINS[r.below(len(ROUTE_ORIGINS))] if k == 0 else ADDR[NAMES[minute // 5 % 3]]
                self.forged_requests.add((origin, rid))
                payload = W.encode_request(rid, origin, r.range(1, 30000), dest, W.UNKNOWN_SEQ, r.below(3),
                                           r.below(64))
                self._control(at + 300 * k, ROUTE_HOPS[r.below(len(ROUTE_HOPS))], sc.BEACON_ALL, payload,
                              "route_request_flood", seal)
        elif kind == 3:
            # forged floods (acomm.transport.flood) from made-up origins: every node would hand
            # them to its application and pass them on
            for k in range(2):
                origin = ROUTE_ORIGINS[r.below(len(ROUTE_ORIGINS))]
                payload = encode_flood(origin, r.below(256), r.below(3), b"all surface " + r.bytes(2))
                self._control(at + 300 * k, ROUTE_HOPS[r.below(len(ROUTE_HOPS))], sc.BEACON_ALL, payload,
                              "route_flood", seal)
        else:
            # replays of sealed route control heard: as heard, to another node, stripped of its
            # seal (what open mode would take); after the AUV's restart, one it heard before
            # (route_replay_restart)
            rec = self.route_recorded
            if rec:
                src, dst, data = rec[-1 - r.below(min(3, len(rec)))]
                # one heard before the AUV's restart is a restart replay, whichever list it came from
                again = "route_replay_restart" if (src, dst, data) in self.route_before_restart else "route_replay"
                self._forge(at, src, dst, data, again)
                other = [a for a in ADDR.values() if a not in (src, dst)]
                self._forge(at + 300, src, other[r.below(len(other))], data, "route_replay")
                f = fr.decode_elided(data, 0, 0)
                self._forge(at + 600, src, dst, fr.encode_elided(fr.Frame(
                    f.ftype, 0, 0, f.seq, unsealed(f.payload), f.flags & ~fr.F_AUTH)), "route_replay")
            if self.restarted and self.route_before_restart:
                old = self.route_before_restart  # those to the AUV or to all
                src, dst, data = old[minute // 5 % len(old)]
                self._forge(at + 900, src, dst, data, "route_replay_restart")

    def table(self, name):
        return self.sn[name].node.transport.router.routing.table

    def _flush(self, now):
        # one packet on the water at a time: its own packets would collide
        keep = []
        for item in self.out:
            if item[0] > now or now < self.busy_until:
                keep.append(item)
                continue
            _, src, dst, data, kind = item
            self.tries[kind] += 1
            if kind.startswith("replay") or kind == "tag_guess":
                self.sealed_tries[(dst, data)] = kind
            elif kind.startswith("route"):
                self.route_tries[data] = (kind, self.tries[kind])  # a success counts once a send
            self.busy_until = self.eve.send(now, src, dst, data)
            if kind == "advert":
                self._check_adverts_at = now + 10000
        self.out = keep
        at = self._check_adverts_at
        if at is not None and now >= at:
            self._check_adverts_at = None
            for name in NAMES:
                am = self.sn[name].node.links["acoustic"].addr_map
                for other in NAMES:
                    if other != name and am.addr_of(ADDR[other]) != ADDR[other]:
                        self.won["advert"] += 1
                        am.set(ADDR[other], ADDR[other])  # put back, so the rest can be measured
