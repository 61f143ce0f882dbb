# A board's node built from its checked configuration (acomm_mp.boardconfig):
# the node and its name table, one link per modem with that modem's sans-IO
# driver, the store-and-forward transport on the board's store, and the
# station (acomm.apps.station) when the board sends reports by itself.
#
# The I/O comes in from outside, so the same assembly runs on a board
# (acomm_mp.start: machine.UART, a store on flash, time.ticks_ms) and in
# tests and the simulator (fake UARTs, a RAM store, a virtual clock):
#   open_uart(link_cfg) -> stream     open_store(storage_cfg) -> store
#
# Board.tick(now) is one round of the main loop. It never lets an error out:
# a MemoryError in the middle of a transfer, or anything a driver raises on
# garbage, is counted, reported once per kind through say(), and the node
# carries on at the next tick (the store still holds every packet).

import gc

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers.registry import driver_class, modem
from acomm.node import Node
from acomm.transport.packetstore import MemoryStore
from acomm.transport import Transport

from .boardconfig import ConfigError


class Board:
    def __init__(self, cfg, node, transport, station, say):
        self.cfg = cfg
        self.node = node
        self.transport = transport
        self.station = station
        self.say = say
        self.wdt = None
        self._gc_due = None
        self.stats = {"ticks": 0, "errors": 0, "oom": 0, "gc": 0}
        self._reported = []  # exception types already reported (at most 8)
        self.mem_peak = 0

    def tick(self, now):
        self.stats["ticks"] += 1
        try:
            self.node.step(now)
            if self.station is not None:
                self.station.poll(now)
        except MemoryError:
            self.stats["oom"] += 1
            gc.collect()
            self._report("MemoryError", "out of memory during a step; packets stay in the store, carrying on")
        except Exception as e:  # noqa: BLE001 - the node must keep running at sea
            self.stats["errors"] += 1
            kind = type(e).__name__
            self._report(kind, "error during a step: %s %s" % (kind, e))
        if self.wdt is not None:
            self.wdt.feed()
        if self._gc_due is None or ticks_diff(now, self._gc_due) >= 0:
            # between steps nothing is half-built: a safe point to collect
            self._gc_due = ticks_add(now, self.cfg["gc_ms"])
            self._measure()
            gc.collect()
            self.stats["gc"] += 1

    def _measure(self):
        alloc = getattr(gc, "mem_alloc", None)
        if alloc is not None:
            a = alloc()
            if a > self.mem_peak:
                self.mem_peak = a

    def _report(self, kind, text):
        # once per exception type, and for at most 8 types: a fault that
        # repeats every tick must not flood the console (stats count all)
        if kind in self._reported or len(self._reported) >= 8:
            return
        self._reported.append(kind)
        self.say("acomm %s: %s" % (self.cfg["name"], text))


def build(cfg, open_uart, clock=None, wall=None, open_store=None, listener=None, say=print, make_report=None):
    node = Node(cfg["name"], cfg["node_id"], clock, listener=listener)
    for name in cfg["peers"]:
        node.names.add(name, cfg["peers"][name])
    a = cfg.get("auth")
    if a is not None:
        from acomm.apps.policy import commands
        from acomm.frame.auth import Auth

        st = cfg["storage"]
        # the counters beside the store, so they survive a restart with it
        path = st["path"] + ".auth" if st is not None and open_store is not None else None
        node.set_auth(Auth(a["key"], a["tag_len"], path, a["reserve"]), commands())
    for i, lk in enumerate(cfg["links"]):
        try:
            cls = driver_class(lk["modem"])
            drv = cls(lk["address"], **lk["options"]) if modem(lk["modem"])[4] else cls(**lk["options"])
        except TypeError as e:
            raise ConfigError("board config: links[%d].options: %s" % (i, e))
        opts = dict(lk["link"])
        opts["medium"] = lk["medium"]
        node.add_link(lk["name"], drv, open_uart(lk), **opts)
    st = cfg["storage"]
    store = open_store(st) if st is not None and open_store is not None else MemoryStore()
    transport = Transport.of(node, store=store, routes=cfg["routes"], wall=wall, max_packet=cfg["max_packet"])
    station = None
    sc = cfg["station"]
    if sc is not None:
        # imported only here: a relay without a station never loads the
        # station's codec and catalog into RAM
        from acomm.apps.station import Station

        station = Station(node, transport, report_to=sc["report_to"], report_period_s=sc["report_period_s"],
                          make_report=make_report, alarm_to=sc["alarm_to"])
    return Board(cfg, node, transport, station, say)
