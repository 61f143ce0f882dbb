# A board's configuration (boards/<name>/config.py) run on the simulated
# ocean: the board's node is built by acomm_mp.assemble exactly as on the
# board, with its UARTs wired to emulated modems instead of machine.UART,
# and ticked by Board.tick (watchdog, gc, errors caught) on virtual time.
# Its peers are plain simulated nodes with their own transports. Runs on
# CPython and on the MicroPython unix port (the fake board runs it after
# `acomm flash`).
#
#   r = run_board(CONFIG, peers={"diver": "seatrac", "shore": "iridium"})
#   r["links"]["acoustic"]["rx_frames"] > 0
#
# Traffic: each peer sends the board a CADDY chat line at 15 s; a peer named
# in `via` also sends one packet through the board to its final
# destination (a diver's packet for shore, relayed by the buoy); a board
# with a station raises an alarm at 20 s. The result says what flowed.

from acomm.catalog import caddy
from acomm.events import EV_PACKET
from acomm.apps.station import diver_report
from acomm.transport import Transport
from acomm_mp.assemble import build
from acomm_mp.boardconfig import check

from .world import World

# modem options that make a simulated minute show something: Iridium
# sessions of 2 s and quick retries instead of the real minutes
_FAST = {
    "iridium": ({"retry_first_ms": 5000, "retry_max_ms": 20000, "mo_mtu": 270}, {"session_ms": 2000}),
}
_QUIET = {"advert_period_ms": 60000}


def _positions(k):
    # peers spread around the board, in range of a SeaTrac
    return (100.0 + 40 * k, 30.0 * k, 10.0)


def fast_options(modem):
    # (driver options, emulator options) for a simulated minute
    return _FAST.get(modem, ({}, {}))


def board_ends(w, lk, position=None):
    # the modem of a board's link (a checked config's links[i]) in the
    # World, with its fast options added to the driver's: -> modem_ends()
    drv_opts, emu_opts = fast_options(lk["modem"])
    for k in drv_opts:
        lk["options"].setdefault(k, drv_opts[k])
    return w.modem_ends(lk["modem"], lk["address"], emu_opts, position)


def add_peers(w, cfg, peers, via, wall, routing=None):
    # the board's peers as simulated nodes with transports: {name: (SimNode,
    # Transport)}; a peer in `via` routes its final destination through the
    # board; routing: the peers' transports learn routes (Transport's option)
    others = {}
    k = 0
    for name in peers:
        modem = peers[name]
        drv_opts, emu_opts = fast_options(modem)
        kind = "satellite" if modem in ("iridium", "sms") else "acoustic"
        lo = dict(_QUIET)
        lo["medium"] = kind
        if kind == "satellite":
            lo.update({"advert_period_ms": 3600000, "ack_timeout_ms": 60000})
        p = w.add(name, cfg["peers"][name], modem, position=_positions(k) if kind == "acoustic" else None,
                  link=kind, driver_opts=dict(drv_opts), emu_opts=dict(emu_opts), link_opts=lo)
        for other in cfg["peers"]:
            if other != name and p.node.names.id_of(other) is None:
                p.node.names.add(other, cfg["peers"][other])
        if p.node.names.id_of(cfg["name"]) is None:
            p.node.names.add(cfg["name"], cfg["node_id"])
        routes = {}
        if via is not None and name in via:
            routes[via[name]] = cfg["name"]
        others[name] = (p, Transport.of(p.node, routes=routes, wall=wall, routing=routing))
        k += 1
    return others


def send_traffic(w, cfg, others, via):
    # each peer's chat line to the board, and its packet through the board
    for name in others:
        t = others[name][1]
        t.send(w.now(), cfg["name"], caddy.CATALOG.pack([(caddy.CHAT, {"text": "hello " + name})]), 600, 5)
        if via is not None and name in via:
            t.send(w.now(), via[name], ("from " + name + " via " + cfg["name"]).encode(), 3600, 6)


def run_board(config, peers, ms=60000, seed=1, via=None, board_position=(0.0, 0.0, 0.0), say=None):
    cfg = check(config)
    w = World(seed=seed)
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    ends = []

    def open_uart(lk):
        ends.append(board_ends(w, lk, board_position if not ends else None))
        return ends[-1][1]

    events = []
    board = build(cfg, open_uart, w.clock, wall, None, listener=events.append, say=say or (lambda s: None),
                  make_report=diver_report(lambda: {}))
    w.adopt(cfg["name"], board.node, ends, step=board.tick, events=events)
    others = add_peers(w, cfg, peers, via, wall)
    w.run(15000)
    send_traffic(w, cfg, others, via)
    w.run(5000)
    if board.station is not None:
        board.station.alarm(w.now(), "low_air")
    w.run(ms - 20000 if ms > 20000 else 0)
    links = {}
    for name in board.node.links:
        st = board.node.links[name].stats
        links[name] = {"tx_frames": st.get("tx_frames", 0), "rx_frames": st.get("rx_frames", 0)}
    got = {}
    for name in others:
        got[name] = [e[1:] for e in others[name][0].events if e[0] == EV_PACKET]
    return {
        "name": cfg["name"],
        "sim_ms": w.now(),
        "links": links,
        "board_packets": [e[1:] for e in events if e[0] == EV_PACKET],
        "peer_packets": got,
        "relayed": board.transport.stats["relayed"],
        "station": None if board.station is None else dict(board.station.stats),
        "inbox": [] if board.station is None else board.station.take_inbox(),
        "board": dict(board.stats),
        "mem_peak": board.mem_peak,
    }
