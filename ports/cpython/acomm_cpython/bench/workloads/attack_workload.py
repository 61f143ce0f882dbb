# `acomm bench attack [--open]`: an attacker without the network key in the
# demo's simulated ocean (docs/demo.md: buoy, diver and AUV on SeaTrac
# beacons at the demo's places, the demo's loss curve, real drivers against
# emulated beacons under a TDMA schedule; every node with a Transport and
# the key, counters on file). The attacker (acomm_sim.attacker) is a
# transceiver 30 m from the buoy that hears everything and sends SeaTrac
# packets under any beacon id. Every 10 minutes the AUV goes out of range
# for 150 s (so that what is sent to it then cannot arrive: a forgery that
# makes it look delivered shows as such), and at minute 35 the AUV
# restarts its key state (its Auth reloaded from its counter file, its
# duplicate filter empty), as a reboot would.
#
# Legitimate traffic: transport packets between every pair (numbered,
# acomm_sim.ledger), and from the buoy to the AUV acknowledged teleop thrust
# commands on the link (each one distinct). Attacks, each tried many times:
#
#   ack             an ACK from the destination for every acknowledged
#                   frame heard, at once
#   sack_complete   a completion SACK (count, packet id read off fragment 0)
#   sack_bitmap     a SACK saying every fragment of the window arrived
#   sack_refusal    a refusal, "too big": the packet fails for good
#   advert          an advert from the attacker's beacon claiming a node's
#                   id: its traffic would go to the attacker
#   replay_same     a sealed frame heard, again, to the same node, with
#                   another sequence number (outside the tag)
#   replay_other    a sealed frame heard, to another node
#   replay_restart  sealed frames heard before the AUV's restart, after it
#   tag_guess       a thrust command "from the buoy" with F_AUTH and a
#                   random counter and tag
#   flood           fragment 0s from 9 made-up sources on both lanes
#   oversize        a fragment 0 announcing a 2 MiB packet, and a
#                   compressed body announcing 1 MiB (decompression bomb)
#   route_reply     a route reply to a node for another, fresher (a higher
#                   sequence number) and cheaper than any it holds, via the
#                   attacker's beacon or via the third node (that one as a
#                   shortcut when the node knows a number: hops 1, the
#                   number it holds, cost 0)
#   route_error     a route error from a live route's next hop naming its
#                   destination, with a raised sequence number
#   route_request_flood
#                   route requests from made-up origins by made-up
#                   neighbours, for a made-up node (every node would pass it
#                   on) or a real one (which would answer)
#   route_flood     floods (acomm.transport.flood) from made-up origins
#   route_replay    sealed route control heard, again as heard, to another
#                   node, and stripped of its seal
#   route_replay_restart
#                   sealed route control to the AUV (or to all) heard before
#                   its restart, after it
#   replay_after_restart
#                   every copy of the buoy's sealed commands to the AUV heard
#                   in the 3 minutes before the AUV's restart, every minute
#                   for 3 minutes after it (every other command's first copy
#                   is lost to noise at the AUV, so the link sends it again
#                   and the attacker holds copies the AUV never took)
#   replay_after_clock_jump
#                   at minute 20 the AUV's clock jumps a day ahead (its
#                   duplicate filter then holds nothing recent); the same
#                   with the commands heard in the 3 minutes before
#   replay_after_hours
#                   after the drain, two idle hours; then every copy of the
#                   commands heard in the first 10 minutes
#   (one route kind a minute in turn, two or three frames; unsealed, or
#   with F_AUTH and a made-up counter and tag, by turns)
#
# Every node routes (Transport(routing=True)). The demo's nodes all hear
# each other, so no packet needs a route; for the route attacks to have
# something to aim at, each node's router is asked every 40 s for a route to
# another node in turn (Routing.search: a request, its rebroadcast, a
# reply), so every table holds live routes (10 minutes each).
#
# Figures per kind: attack_<kind>_tries and attack_<kind>_succeeded, where
# success is what the attack is for: ack, a thrust command reported
# delivered that the AUV never received; sack_complete, a packet reported
# delivered that never arrived; sack_bitmap, a forged SACK taken as the
# receiver's word on a live transfer; sack_refusal, a packet failed by a
# refusal its receiver never sent; advert, a node's address map moved (the
# bench puts it back so that the other attacks still have a network);
# replay_* and tag_guess, a frame the key took for the second time
# (or, for a guess, at all) and that reached an application again (for the
# replay_after_* kinds: a command the AUV's application had, handed to it
# again, whichever copy the key took); flood, a legitimate sealed transfer refused
# "receiver full"; oversize, a node that stopped (an exception out of its
# step) or reassembly memory past its bound; route_reply, route_error,
# route_request_flood and route_flood, a forged frame after which a node
# that took it held another route table (a route added, moved, refreshed or
# invalidated), passed something on (a rebroadcast, a reply, an error) or
# handed a flood to its application (counted once a frame); route_replay*,
# the same for a frame whose content the node had taken before (a replay
# that arrived before its lost original only delivered it). Besides,
# attack_route_request_flood_amplification and
# attack_route_flood_amplification: control frames the nodes sent for the
# forged requests (rebroadcasts, replies to their made-up origins) or floods
# per forged frame. Then the legitimate traffic: packets lost and duplicated
# (the ledger's rules), delivered, reported expired (the attacker's air
# jams as well: a jammer needs no key), commands lost.
import os
import shutil
import tempfile

from acomm import frame as fr
from acomm.compat import ticks_add
from acomm.transport import segment as sg
from acomm.apps.policy import commands
from acomm.frame.auth import Auth
from acomm.catalog import teleop
from acomm.events import (DELIVERED, EXPIRED, EV_PACKET, EV_PACKET_STATUS, EV_RECEIVED, EV_STATUS, FAILED, is_final)
from acomm.link.dedup import DuplicateFilter
from acomm.drivers.mac import Tdma
from acomm.prng import Prng
from acomm.transport import Transport
from acomm.transport import _MAX_RX
from acomm.transport import routing as W
from acomm_sim.attacker import Attacker
from acomm_sim.channel import Channel
from acomm_sim.ledger import Ledger
from acomm_sim.world import World

from ...demo.places import ADDR, AUV, BUOY, DIVER, LOSS_CURVE, START
from .attack_eve import EVE, NAMES, ROUTE_ORIGINS, Forger, unsealed
from .soak_workload import payload

KEY = bytes(range(7, 39))  # the bench's network key (32 bytes)
GUARD_MS = 300
SLOTS = ((BUOY, 7000, GUARD_MS), (DIVER, 10000, GUARD_MS), (AUV, 7000, GUARD_MS))
TX_MS = 3000
EVE_AT = (25.0, 15.0, 3.0)
FAR = (5000.0, 0.0, 6.0)  # the AUV out of range
KINDS = ("ack", "sack_complete", "sack_bitmap", "sack_refusal", "advert", "replay_same", "replay_other",
         "replay_restart", "tag_guess", "flood", "oversize", "route_reply", "route_error", "route_request_flood",
         "route_flood", "route_replay", "route_replay_restart", "replay_after_restart", "replay_after_clock_jump",
         "replay_after_hours")
AFTER = ("replay_after_restart", "replay_after_clock_jump", "replay_after_hours")
BY_ADDR = dict((ADDR[n], n) for n in NAMES)
# the legitimate route searches: (from, to), one every 40 s in turn
SEARCHES = ((BUOY, AUV), (DIVER, BUOY), (AUV, DIVER), (BUOY, DIVER), (DIVER, AUV), (AUV, BUOY))
MINUTES = 60
RESTART_MS = 35 * 60000
JUMP_MS = 20 * 60000
LIFESPAN_S = 3000
IDLE_MS = 2 * 3600000  # before replay_after_hours
EARLY_MS = 10 * 60000  # the commands it replays were heard before this


class Attack(Forger):
    def __init__(self, strict=True, seed=1, minutes=MINUTES, lifespan_s=LIFESPAN_S, restart_ms=RESTART_MS,
                 jump_ms=JUMP_MS, early_ms=EARLY_MS):
        """lifespan_s: the legitimate packets' (the drain lasts until the last is settled);
        restart_ms: when the AUV restarts its key state; jump_ms: when its clock jumps; early_ms:
        the commands replayed after the idle hours were heard before it. A shorter run (a test)
        may shorten them."""
        self.strict = strict
        self.lifespan_s = lifespan_s
        self.restart_ms = restart_ms
        self.jump_ms = jump_ms
        self.early_ms = early_ms
        self.cmd_recorded = []  # (when, src, dst, bytes): every sealed command copy heard, buoy to AUV
        self.jumped = False
        self.noised = set()  # commands whose first copy the AUV lost to noise
        self.dir = tempfile.mkdtemp(prefix="acomm-attack-")
        self.channel = Channel(seed=seed, loss_curve=LOSS_CURVE)
        self.w = w = World(seed=seed, channel=self.channel, step_ms=20, max_quiet_ms=200)
        self.minutes = minutes
        self.rng = Prng(seed * 17 + 5)
        self.ledger = Ledger()
        self.tries = dict((k, 0) for k in KINDS)
        self.won = dict((k, 0) for k in KINDS)
        self.deaths = 0
        self.strange = 0
        self.first_copies = 0
        self.taken_again = {}
        self.handed = dict((ADDR[n], 0) for n in NAMES)  # deliveries to each application
        self.sn = {}
        for name in NAMES:
            sn = w.add(name, ADDR[name], "seatrac", position=START[name], mac=Tdma(SLOTS, name, 0, TX_MS),
                       link_opts={"advert_period_ms": 60000, "queue_capacity": 64, "max_retries": 100},
                       listener=self._listener(name))
            sn.node.set_auth(Auth(KEY, path=self._counters(name)), commands(), strict=strict)
            Transport.of(sn.node, wall=lambda: w.now() // 1000, routing=True)
            sn.step = self._stepper(sn)
            self.sn[name] = sn
        self.route_rng = Prng(seed * 31 + 7)
        self.route_recorded = []  # (src, dst, bytes) sealed route control heard, the latest 40
        self.route_before_restart = []
        self.route_tries = {}  # bytes of a forged or replayed route control frame -> kind
        self.route_taken = dict((ADDR[n], set()) for n in NAMES)  # (src, control payload) each node took
        self.route_first_copies = 0
        self.route_won = set()  # (kind, try) that succeeded
        self.forged_requests = set()  # (origin, request id)
        self.amplified = 0  # control frames the nodes sent for forged requests
        self.flood_amplified = 0  # and for forged floods
        self.floods_handed = 0
        self.search_turn = 0
        self._spy_sacks()
        self._spy_sealed()
        self._spy_routes()
        self.eve = Attacker(self.channel, EVE, EVE_AT, self._heard)
        self.recorded = []  # (src, dst, bytes) sealed frames heard, the latest 40
        self.before_restart = []
        self.pids = {}  # (src, dst, lane) -> (pid, count) read off a fragment 0
        self.sack_turn = 0
        self.out = []  # [when, src, dst, bytes, kind]: forged packets waiting for the channel
        self.forged = {}  # (head, payload) of a forged SACK -> kind
        self.commands = {}  # thrust payload -> [link request id, delivered?, times received]
        self.cmd_rids = {}
        self.cmd_seq = 0
        self.restarted = False
        self.far = False
        self.max_rx_bytes = 0
        self._m = -1
        self._offset = 0
        self.sealed_tries = {}  # (beacon, bytes) of a replay or a tag guess -> kind
        self.busy_until = 0
        self._check_adverts_at = None
        self.refused_before = {}  # the AUV's refusals before its restart
        self.saves_before = 0  # and its counter file writes
        self.saves_per_hour = {}
        self._noise_first_copies()

    def _noise_first_copies(self):
        # every other command's first copy is lost to noise at the AUV: its sender's link sends
        # it again, and the attacker holds a copy the AUV never took, the copy of the hole this
        # bench once found (copies 24 and 25, the AUV took 25, the replay of 24 later was
        # fresh). The attacker records every copy of a command with a hydrophone that only
        # listens (its transceiver, busy with its own packets most of each minute, hears few)
        ch = self.channel
        transmit = ch.transmit

        def spy(now, src, packet, airtime_ms):
            if src == ADDR[BUOY] and getattr(packet, "dst", None) == ADDR[AUV]:
                c = self.commands.get(_command_of(packet.data))
                if c is not None and not [x for x in self.cmd_recorded if x[3] == packet.data]:
                    # each copy once (a copy sealed once is one recording however often it went)
                    self.cmd_recorded.append((now, src, ADDR[AUV], packet.data))
                if c is not None and c[0] % 2 == 0 and c[0] not in self.noised:
                    self.noised.add(c[0])
                    ch.noise_burst(now, airtime_ms + 1000, ADDR[AUV])
            return transmit(now, src, packet, airtime_ms)

        ch.transmit = spy

    def _counters(self, name):
        return os.path.join(self.dir, name + ".auth")

    # -- the nodes ------------------------------------------------------------------
    def _stepper(self, sn):
        node = sn.node

        def step(now):
            try:
                node.step(now)
            except Exception:  # a node that stopped: the oversize attack's aim
                self.deaths += 1
                self.won["oversize"] += 1
        return step

    def _listener(self, name):
        me = ADDR[name]
        led = self.ledger

        def on_event(ev):
            code = ev[0]
            if code == EV_PACKET or code == EV_RECEIVED:
                self.handed[me] += 1
            if code == EV_PACKET_STATUS:
                led.status(me, ev[1], ev[2])
                if ev[2] == FAILED and "too big" in ev[3]:
                    self.won["sack_refusal"] += 1
            elif code == EV_PACKET:
                data = ev[3]
                if ev[2] == "*":
                    self.floods_handed += 1  # a flood: nobody with the key sends one here
                    return
                if ev[2] != name or len(data) < 4:
                    led.delivered(-1, False)
                    return
                seq = int.from_bytes(data[:4], "big")
                led.delivered(seq, data == payload(seq, len(data)))
            elif code == EV_RECEIVED:
                c = self.commands.get(bytes(ev[4]))
                if c is None or name != AUV:
                    self.strange += 1  # a command nobody with the key sent, or at the wrong node
                else:
                    c[2] += 1
            elif code == EV_STATUS and name == BUOY and is_final(ev[3]):
                c = self.cmd_rids.pop(ev[2], None)
                if c is not None:
                    c[1] = ev[3] == DELIVERED
                    c[3] = ev[3]
        return on_event

    def _spy_sacks(self):
        # which forged SACKs a sender's transport took as its receiver's
        # word (reached _on_sack with a live transfer), and which sealed
        # transfers a receiver refused "receiver full"
        for name in NAMES:
            t = self.sn[name].node.transport
            on_segment, send_sack = t.on_segment, t._sack

            def spy(now, link, src, dst, head, data, authed=False, t=t, on_segment=on_segment):
                kind = None if authed else self.forged.get((head, bytes(data)))
                bad = t.stats["rx_bad"]
                refused = sum(t.guard.refused.values())
                on_segment(now, link, src, dst, head, data, authed)
                # a routing node is handed the segments it overhears too (for shortcuts): only the
                # one the forgery was addressed to can take it
                if kind == "sack_bitmap" and dst == t.node_id and t.stats["rx_bad"] == bad and sum(
                        t.guard.refused.values()) == refused:
                    self.won[kind] += 1
                n = sum(r.size for r in t._rx.values())
                self.max_rx_bytes = max(self.max_rx_bytes, n)
                if len(t._rx) > _MAX_RX or n > _MAX_RX * (t.max_packet + 16):
                    self.won["oversize"] += 1

            def sack(now, link, src, seg, tries=0, send_sack=send_sack):
                if src in ADDR.values() and seg[0] & 12 == 12 and len(seg[1]) == 2 and seg[1][1] == sg.REFUSE_FULL:
                    self.won["flood"] += 1
                send_sack(now, link, src, seg, tries)

            t.on_segment = spy
            t._sack = sack

    def _spy_sealed(self):
        # a replay or a guessed tag succeeds when the node's key takes it
        # as fresh and genuine (its Auth opened it)
        for name in NAMES:
            link = self.sn[name].node.links["acoustic"]
            on_rx = link._on_rx

            seen = set()  # counter and tag of every sealed frame this node took

            def spy(now, src_addr, dst_addr, data, link=link, on_rx=on_rx, me=ADDR[name], seen=seen):
                kind = self.sealed_tries.get((me, bytes(data)))
                rtry = self.route_tries.get(bytes(data))
                if rtry is not None:
                    before = self._route_state(me)
                    known = (src_addr, _control_body(data)) in self.route_taken[me]
                auth = link.framing.auth
                opened = auth.stats["opened"]
                handed = self.handed[me]
                cmd = self.commands.get(_command_of(data)) if kind in AFTER else None
                had = cmd[2] if cmd is not None else 0
                on_rx(now, src_addr, dst_addr, data)
                if kind in AFTER:
                    # a command the application had, handed to it again (by whichever copy: the
                    # hole closed here was a resent copy with a counter of its own)
                    if cmd is not None and had and cmd[2] > had:
                        self.won[kind] += 1
                    if auth.stats["opened"] > opened:
                        if had:
                            self.taken_again[kind] = self.taken_again.get(kind, 0) + 1
                        else:
                            self.first_copies += 1  # the AUV had no copy: the attacker only delivered it
                    return
                if rtry is not None:
                    self._route_outcome(rtry, before, self._route_state(me), known,
                                        auth.stats["opened"] > opened and (src_addr, bytes(data[-7:])) in seen)
                if auth.stats["opened"] == opened:
                    return
                sig = (src_addr, bytes(data[-7:]))
                if kind is not None:
                    if sig in seen:
                        # taken twice by the key: the restart's window
                        # (docs/wire-format.md); it succeeds when something
                        # reached the application again (the transport's
                        # own duplicate check stops a fragment's packet)
                        self.taken_again[kind] = self.taken_again.get(kind, 0) + 1
                        if self.handed[me] > handed:
                            self.won[kind] += 1
                    else:
                        self.first_copies += 1  # the original never came: the attacker only delivered it
                seen.add(sig)

            link._on_rx = spy

    def _routing(self, addr):
        return self.sn[BY_ADDR[addr]].node.transport.router.routing

    def _route_state(self, me):
        # what a route control frame can change at node me: its routes (all but when last used),
        # and what it passed on
        rt = self._routing(me)
        st = rt.finder.stats
        t = rt.table.routes
        return (dict((d, tuple(t[d][:6])) for d in t), st["rebroadcasts"], st["replies"], st["errors"],
                rt.flooder.stats["delivered"] if rt.flooder is not None else 0, self.handed[me])

    def _route_outcome(self, rtry, before, after, known, again):
        # a forged or replayed route control frame taken by a node: it succeeds when the node's
        # routes or what it passed on changed, once a send however many nodes took it; a replay
        # only on content the node had taken before (else it only delivered a lost original)
        kind = rtry[0]
        replay = kind.startswith("route_replay")
        if replay and again:
            self.taken_again[kind] = self.taken_again.get(kind, 0) + 1  # a seal opened twice
        if before == after:
            return
        if replay and not known:
            self.route_first_copies += 1
        elif rtry not in self.route_won:
            self.route_won.add(rtry)
            self.won[kind] += 1

    def _spy_routes(self):
        # the route control each node took (a replay succeeds only on content taken before), and
        # the control frames it sent for forged requests (the amplification)
        for name in NAMES:
            t = self.sn[name].node.transport
            rt = t.router.routing
            taken = self.route_taken[ADDR[name]]

            def on_control(now, link, src, payload, *authed, on_control=t.on_control, taken=taken):
                on_control(now, link, src, payload, *authed)
                taken.add((src, bytes(payload)))

            def send(now, link_name, to, payload, rt=rt, send=rt._send):
                sent = rt.stats["control_sent"]
                send(now, link_name, to, payload)
                if rt.stats["control_sent"] > sent:
                    k = _answers_forgery(payload, self.forged_requests)
                    if k == "flood":
                        self.flood_amplified += 1
                    elif k:
                        self.amplified += 1

            t.on_control = on_control
            rt._send = send

    # -- legitimate traffic ------------------------------------------------------------
    def poll(self, now):
        # every 40 s a packet between a pair; every 80 s a thrust command
        r = self.rng
        src = NAMES[r.below(3)]
        dst = [n for n in NAMES if n != src][r.below(2)]
        led = self.ledger
        seq = led.begin(ADDR[src])
        size = r.range(6, 26) if r.chance(0.6) else r.range(40, 160)
        pid = self.sn[src].node.transport.send(now, dst, payload(seq, size), self.lifespan_s, r.range(3, 12))
        led.sent(seq, ADDR[src], pid)
        if (now // 40000) % 2 == 0:
            self._command(now)
        # a route search (nothing when the node holds a live route to it)
        a, b = SEARCHES[self.search_turn % len(SEARCHES)]
        self.search_turn += 1
        self.sn[a].node.transport.router.routing.search(now, ADDR[b])
        return now + 40000

    def _command(self, now):
        i = self.cmd_seq
        self.cmd_seq += 1
        v = ((i % 41 - 20) / 20, (i // 41 % 41 - 20) / 20, 0, 0, 0, 0)
        data = teleop.CATALOG.pack([(teleop.THRUST, teleop.thrust_values(v, i % teleop.SEQ_MOD))])
        node = self.sn[BUOY].node
        # a lifespan within the link's duplicate window (60 s): a resend
        # later than that would be a new frame to the receiver (key or not)
        rid = node.send("acoustic", AUV, data, 60, 2, ack=True, now=now)
        c = self.commands.setdefault(data, [rid, False, 0, None])
        self.cmd_rids[rid] = c

    # -- the plan ------------------------------------------------------------------------
    def _plan(self, now):
        # the AUV's shadow, and its restart
        t = now % 600000
        far = 300000 <= t < 450000
        if far != self.far:
            self.far = far
            pos = FAR if far else START[AUV]
            self.channel.set_position(ADDR[AUV], pos[0], pos[1], pos[2])
        if not self.jumped and now >= self.jump_ms:
            # the AUV's clock jumps a day ahead: what its duplicate filter remembers is a day
            # old (the counter window does not go by time); the attacker's replays follow
            # (attack_eve)
            self.jumped = True
            dups = self.sn[AUV].node.links["acoustic"]._dups
            for lst in dups._recent.values():
                for e in lst:
                    e[1] = ticks_add(e[1], -86400000)
        if not self.restarted and now >= self.restart_ms:
            self.restarted = True
            self.before_restart = list(self.recorded)
            # those to the AUV or to all (0)
            self.route_before_restart = [x for x in self.route_recorded if x[1] in (ADDR[AUV], 0)]
            node = self.sn[AUV].node
            self.refused_before = dict(node.guard.refused)
            self.saves_before = node.auth.stats["saves"]
            node.set_auth(Auth(KEY, path=self._counters(AUV)), commands(), strict=self.strict)
            node.links["acoustic"]._dups = DuplicateFilter(60000)

    def run(self):
        w = self.w
        attack = self

        class _Eve:
            def poll(self, now):
                attack._plan(now)
                attack.attack(now)
                return now + 100

        w.add_task(self)
        self._eve_task = _Eve()
        w.add_task(self._eve_task)
        end = w.now() + self.minutes * 60000
        while w.now() < end:
            w.run(min(600000, end - w.now()))
        w.remove_task(self)
        # counter file writes (flash writes on a board) per hour of the attack, each node
        for name in NAMES:
            n = self.sn[name].node.auth.stats["saves"] + (self.saves_before if name == AUV else 0)
            self.saves_per_hour[name] = round(n * 60 / self.minutes, 1)
        self.channel.set_position(ADDR[AUV], START[AUV][0], START[AUV][1], START[AUV][2])
        self.far = None
        # the attacker stops too; the legitimate traffic drains
        led = self.ledger
        limit = w.now() + 2 * self.lifespan_s * 1000
        while (led.pending() or self.cmd_rids) and w.now() < limit:
            w.run(600000, until=lambda: not led.pending() and not self.cmd_rids)
        self._after_hours()
        return self

    def _after_hours(self):
        # two idle hours (nothing but adverts: the world skips the quiet time), then the
        # attacker plays every copy of the commands it heard in the first minutes to the AUV
        w = self.w
        w.remove_task(self._eve_task)  # the attacker waits too: the world skips the quiet time
        w.run(IDLE_MS)
        now = w.now()
        for when, src, dst, data in self.cmd_recorded:
            if when < self.early_ms:
                self._forge(now, src, dst, data, "replay_after_hours")
        end = now + 60000 + 4000 * len(self.out)
        while w.now() < end and self.out:
            w.run(1000)
            self._flush(w.now())
        w.run(10000)

    def figures(self):
        f = {}
        for c in self.commands.values():
            if c[1] and not c[2]:
                self.won["ack"] += 1  # reported delivered, never received
        lost = self.ledger.lost()
        dups = self.ledger.counts["duplicates"]
        self.won["sack_complete"] += lost  # accepted, reported delivered, never arrived (or lost)
        for k in KINDS:
            f["attack_%s_tries" % k] = self.tries[k]
            f["attack_%s_succeeded" % k] = self.won[k]
        f["attack_legit_packets_accepted"] = self.ledger.counts["accepted"]
        f["attack_legit_packets_lost"] = lost
        f["attack_legit_packets_duplicated"] = dups
        f["attack_legit_packets_failed"] = self.ledger.counts["status_failed"]
        # reported expired: the attacker's air is jamming too (a jammer needs no key)
        f["attack_legit_packets_expired"] = self.ledger.counts["status_expired"]
        f["attack_legit_packets_delivered"] = self.ledger.counts["delivered"]
        f["attack_legit_commands_sent"] = len(self.commands)
        f["attack_legit_commands_lost"] = sum(1 for c in self.commands.values() if not c[2] and c[3] not in (
            EXPIRED, FAILED))
        f["attack_legit_commands_expired_or_failed"] = sum(1 for c in self.commands.values() if c[3] in (EXPIRED, FAILED))
        f["attack_legit_commands_duplicated"] = sum(c[2] - 1 for c in self.commands.values() if c[2] > 1)
        f["attack_commands_not_sent_obeyed"] = self.strange
        f["attack_replay_first_copies"] = self.first_copies
        for k in sorted(self.taken_again):
            f["attack_%s_frames_taken_again" % k] = self.taken_again[k]
        n = self.tries["route_request_flood"]
        f["attack_route_request_flood_amplification"] = round(self.amplified / n, 3) if n else 0
        n = self.tries["route_flood"]
        f["attack_route_flood_amplification"] = round(self.flood_amplified / n, 3) if n else 0
        f["attack_route_floods_handed"] = self.floods_handed
        f["attack_route_replay_first_copies"] = self.route_first_copies
        # routes left at the end whose next hop is the attacker's beacon
        f["attack_routes_via_attacker"] = sum(1 for n in NAMES for e in self._routing(ADDR[n]).table.routes.values()
                                              if e[0] == EVE)
        f["attack_legit_route_requests"] = sum(self._routing(ADDR[n]).finder.stats["requests"] for n in NAMES)
        f["attack_legit_route_control_sent"] = sum(self._routing(ADDR[n]).stats["control_sent"] for n in NAMES)
        for name in NAMES:
            f["attack_auth_saves_per_hour_" + name] = self.saves_per_hour.get(name, 0)
        f["attack_node_deaths"] = self.deaths
        f["attack_max_reassembly_bytes"] = self.max_rx_bytes
        refused = dict(self.refused_before)
        for name in NAMES:
            for k, v in self.sn[name].node.guard.refused.items():
                refused[k] = refused.get(k, 0) + v
        for k in sorted(refused):
            f["attack_refused_" + k] = refused[k]
        return f

    def close(self):
        shutil.rmtree(self.dir, ignore_errors=True)


UNITS = {"attack_max_reassembly_bytes": "B", "attack_auth_saves_per_hour_buoy": "/h", "attack_auth_saves_per_hour_diver": "/h",
         "attack_auth_saves_per_hour_auv": "/h", "attack_route_request_flood_amplification": "x",
         "attack_route_flood_amplification": "x"}


def _command_of(data):
    # a sealed DATA frame on the water -> its payload without the seal's trailer (None otherwise)
    try:
        f = fr.decode_elided(data, 0, 0)
    except Exception:
        return None
    return unsealed(f.payload) if f.ftype == fr.DATA and f.flags & fr.F_AUTH else None


def _control_body(data):
    # a CONTROL frame on the water -> its payload without a seal's trailer (None for other frames)
    try:
        f = fr.decode_elided(data, 0, 0)
    except Exception:
        return None
    return unsealed(f.payload) if f.flags & fr.F_AUTH else bytes(f.payload)


def _answers_forgery(payload, forged):
    # a control frame a node sent because of a forged request: its rebroadcast, or a reply to (or
    # an error naming) a made-up origin
    try:
        m = W.decode(payload)
    except Exception:
        return False
    if m[0] == "request":
        return (m[2], m[1]) in forged
    if m[0] == "reply":
        return m[3] in ROUTE_ORIGINS
    if m[0] == "error":
        return any(d in ROUTE_ORIGINS for d, _ in m[1])
    return "flood" if m[1] in ROUTE_ORIGINS else False


def run(emit, open_mode=False, quick=False):
    a = Attack(strict=not open_mode, minutes=3 if quick else MINUTES)
    try:
        a.run()
        f = a.figures()
    finally:
        a.close()
    if open_mode:
        emit("attack_mode_open", 1, "flag")
    for k in f:
        emit(k, f[k], UNITS.get(k, "count"))
    for k, v in frame_costs().items():
        emit(k, v, "B")
        emit(k.replace("auth_bytes_", "auth_airtime_80bps_"), v * 8 / 80, "s")


def frame_costs():
    # bytes on the air of the control frames, without and with the key
    # (acomm.link.framing, as the links encode them); -> {name: bytes}
    from acomm.link.framing import LinkFraming
    from acomm.link.names import AddressMap

    out = {}
    for form, elided, link_acks in (("elided", True, False), ("elided_linkack", True, True), ("raw", False, True)):
        for keyed in (False, True):
            f = LinkFraming(1, elided, AddressMap(True, 0), 64, link_acks)
            if keyed:
                f.set_auth(Auth(KEY))
            tag = "sealed" if keyed else "plain"
            frames = (("sack_complete", fr.SEGMENT) + sg.sack_complete(0, 1, 3, 77),
                      ("sack_bitmap", fr.SEGMENT) + sg.sack(0, 1, 3, b"\x05"),
                      ("sack_refusal", fr.SEGMENT) + sg.sack_refused(0, 1, sg.REFUSE_FULL))
            if link_acks:  # an acomm ACK goes on the air only where the modem does not acknowledge
                frames = (("ack", fr.ACK, 5, b""),) + frames
            for name, ftype, head, body in frames:
                # an ACK's tag is bound to the counter of the frame it acknowledges (here 1)
                out["auth_bytes_%s_%s_%s" % (name, form, tag)] = len(f.encode(ftype, 2, head, body, 0, 1)[1])
    return out
