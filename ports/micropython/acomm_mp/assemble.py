# A board's node built from its checked configuration (acomm_mp.boardconfig):
# the node and its name table, one link per modem with that modem's sans-IO
# driver, the store-and-forward transport on the board's store, and the
# station (acomm.apps.station) when the board sends reports by itself.
#
# The wall clock (acomm.wallclock): given the port's wall(), the node keeps
# one clock that its drivers' times set (and a GPS's, with a `gps` entry),
# its last good time in a file beside the store; the key and the transport
# read that clock.
#
# The I/O comes in from outside, so the same assembly runs on a board
# (acomm_mp.start: machine.UART, a store on flash, time.ticks_ms) and in
# tests and the simulator (fake UARTs, a RAM store, a virtual clock):
#   open_uart(link_cfg) -> stream     open_store(storage_cfg) -> store
#
# Needed once, at boot: a board releases this module and the modem registry
# once the node is built (acomm_mp.release_builder), and their code and
# tables go back to the heap. The Board it returns lives in acomm_mp.runloop.

from acomm.drivers.registry import driver_class, modem
from acomm.node import Node
from acomm.transport import Transport

from .boardconfig import ConfigError
from .runloop import Board


def build(cfg, open_uart, clock=None, wall=None, open_store=None, listener=None, say=print, make_report=None):
    import gc

    # the UARTs and the drivers first: their buffers (a receive ring of
    # 1152 B at 115200 baud, an AT driver's line and block) each need one
    # free run of the heap, which the build's smaller objects would break
    # up; and a collection after each part of the build, so its garbage is
    # reused before the next part's objects land beyond it (a board's heap
    # is then less fragmented when the node starts)
    uarts = [open_uart(lk) for lk in cfg["links"]]
    drvs = []
    for i, lk in enumerate(cfg["links"]):
        try:
            cls = driver_class(lk["modem"])
            drvs.append(cls(lk["address"], **lk["options"]) if modem(lk["modem"])[4] else cls(**lk["options"]))
        except TypeError as e:
            raise ConfigError("board config: links[%d].options: %s" % (i, e))
    st = cfg["storage"]
    wc = None
    if wall is not None:
        from acomm.wallclock import WallClock

        # the last good time beside the store, so a board without a
        # battery clock never starts again earlier than it
        wc = WallClock(wall, clock, st["path"] + ".clock" if st is not None and open_store is not None else None)
        wall = wc.wall
        gc.collect()
    node = Node(cfg["name"], cfg["node_id"], clock, listener=listener, wallclock=wc)
    for name in cfg["peers"]:
        node.names.add(name, cfg["peers"][name])
    gc.collect()
    a = cfg.get("auth")
    if a is not None:
        from acomm.apps.policy import commands
        from acomm.frame.auth import Auth

        # the counters beside the store, so they survive a restart with it
        path = st["path"] + ".auth" if st is not None and open_store is not None else None
        node.set_auth(Auth(a["key"], a["tag_len"], path, a["reserve"], wall), commands())
        gc.collect()
    for i, lk in enumerate(cfg["links"]):
        opts = dict(lk["link"])
        opts["medium"] = lk["medium"]
        node.add_link(lk["name"], drvs[i], uarts[i], **opts)
        gc.collect()
    g = cfg.get("gps")
    if g is not None:
        # imported only here: a board without a GPS never loads the reader
        from acomm.drivers.gps import GpsReader

        uarts.append(open_uart(g))
        node.add_time_source(GpsReader(), uarts[-1])
    # no store: the transport keeps its packets in RAM (a MemoryStore)
    store = open_store(st) if st is not None and open_store is not None else None
    gc.collect()
    # routing: None (absent) loads nothing of the route finder; True or a dict: learned routes
    transport = Transport.of(node, store=store, routes=cfg["routes"], wall=wall, max_packet=cfg["max_packet"],
                             routing=cfg.get("routing"))
    gc.collect()
    station = None
    sc = cfg["station"]
    if sc is not None:
        # imported only here: a relay without a station never loads the
        # station's codec and catalog into RAM
        from acomm.apps.station import Station

        station = Station(node, transport, report_to=sc["report_to"], report_period_s=sc["report_period_s"],
                          make_report=make_report, alarm_to=sc["alarm_to"])
    return Board(cfg, node, transport, station, say, uarts)
