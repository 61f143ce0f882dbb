# The attacker's side of `acomm bench attack` (attack_workload): what it
# answers to what it hears, and its own schedule. A mixin of the bench's
# Attack, whose attributes it uses: eve (acomm_sim.attacker.Attacker), rng,
# tries and won (per kind), recorded and before_restart (sealed frames
# heard), pids, forged and sealed_tries (what it sent, for the spies), out
# (packets waiting for the channel), restarted, sn (the nodes).
from acomm import frame as fr
from acomm.transport import segment as sg
from acomm.catalog import teleop
from acomm.codec.compress import compress
from acomm.drivers import seatrac_codes as sc

from ...demo.places import ADDR, AUV, BUOY, DIVER

NAMES = (BUOY, DIVER, AUV)
EVE = 14  # the attacker's own beacon id


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
            self.recorded.append((p.src, p.dst, p.data))
            if len(self.recorded) > 40:
                self.recorded.pop(0)
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
        self._flush(now)

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
