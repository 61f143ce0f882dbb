# A board's configuration (boards/<name>/config.py: CONFIG = {...}) checked
# at start, before anything is opened: a missing or wrong field stops the
# board with a message that names the field, e.g.
#   board config: links[1].baud: an integer 300..4000000, not 'fast'
# check() returns a copy with every default filled in, so the rest of the
# port reads fields without guessing.
#
# Fields (see boards/*/config.py for two complete examples):
#   name          node name, 1..16 characters
#   node_id       1..254 (255 is broadcast)
#   arch          mpy-cross -march of the MCU (armv6m for an RP2040,
#                 xtensawin for an ESP32-S3); `acomm flash` reads it
#   mpy_lines     absent or True: the .mpy files `acomm flash` copies keep
#                 their line numbers; False: none (tracebacks name the
#                 module and function only), about 4 KB less heap for the
#                 buoy's modules loaded from flash (no effect when frozen)
#   peers         {name: node id} of the other nodes it talks to
#   routes        {final destination: next hop}, both known names
#   routing       absent or False: static routes only, and the routing
#                 modules are never loaded; True, or a dict of
#                 acomm.transport.routing.Routing's options (media, capacity,
#                 tries, search_ms, hold_ms, lifetime_ms, jitter_ms, seed,
#                 ring): routes are learned on the acoustic links (route
#                 requests, replies, errors; static routes still win), for
#                 about 3.5 KB more heap on the buoy (docs/routing.md)
#   storage       {"path", "capacity", "max_record"} of the packet store on
#                 flash, or None to keep packets in RAM only
#   max_packet    the transport's largest packet, bytes
#   watchdog_ms   machine.WDT timeout, 0 for none
#   step_ms       main loop period; gc_ms: garbage collection period
#   idle_ms       step_ms..10000: how often the loop steps a node that has
#                 nothing to do (no bytes waiting on its UARTs, none moved
#                 by its last step; acomm_mp.runloop), default 100
#   links         one dict per modem: name, modem (acomm.drivers.registry), uart,
#                 baud, tx and rx pins (None: the board's default), address
#                 (default node_id), medium, link (Link options), options
#                 (driver options)
#   gps           absent or None, or {"uart", "baud" (9600), "tx", "rx",
#                 "rxbuf" (256)}: a GPS receiver's NMEA output on its own
#                 UART, read for the time only (acomm.drivers.gps)
#   station       None, or {"report_to", "report_period_s", "alarm_to"}:
#                 what acomm.apps.station.Station sends by itself
#   web           absent, None, or {"host" (default loopback), "port" (80),
#                 "password", "log_size", "max_streams"}: the operator
#                 console in a browser (acomm_web.board; docs/console.md),
#                 for a board with a network; the buoy has none

from acomm.errors import AcommError

from acomm.drivers.registry import names as modem_names

# the -march values mpy-cross (1.23 and later) knows
ARCHES = ("x64", "x86", "armv6", "armv6m", "armv7m", "armv7em", "armv7emsp", "armv7emdp", "xtensa", "xtensawin",
          "rv32imc", "rv64imc")

_LINK_OPTIONS = ("queue_capacity", "advert_period_ms", "lost_after", "ack_timeout_ms", "max_retries", "aging_ms",
                 "dup_window_ms", "ack_window", "overhear", "fec")


class ConfigError(AcommError):
    pass


def _fail(field, want, got):
    raise ConfigError("board config: %s: %s, not %r" % (field, want, got))


def _int(d, key, lo, hi, field, default=None):
    v = d.get(key, default)
    if v is None and default is None and key not in d:
        raise ConfigError("board config: %s: missing" % field)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        _fail(field, "an integer %d..%d" % (lo, hi), v)
    return v


def _str(d, key, field, maxlen=16, default=None):
    v = d.get(key, default)
    if v is None and key not in d and default is None:
        raise ConfigError("board config: %s: missing" % field)
    if not isinstance(v, str) or not 1 <= len(v) <= maxlen:
        _fail(field, "a string of 1..%d characters" % maxlen, v)
    return v


def _dict(d, key, field, default):
    v = d.get(key, default)
    if v is None:
        return default
    if not isinstance(v, dict):
        _fail(field, "a dict", v)
    return v


def _pin(d, key, field):
    v = d.get(key)
    if v is not None and (isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 99):
        _fail(field, "a pin number 0..99 or None", v)
    return v


def _link(i, lk, node_id, names):
    f = "links[%d]" % i
    if not isinstance(lk, dict):
        _fail(f, "a dict", lk)
    out = {}
    out["name"] = name = _str(lk, "name", f + ".name")
    if name in names:
        _fail(f + ".name", "a name no other link has", name)
    names.append(name)
    modem = lk.get("modem")
    if modem not in modem_names():
        _fail(f + ".modem", "one of " + ", ".join(modem_names()), modem)
    out["modem"] = modem
    out["uart"] = _int(lk, "uart", 0, 9, f + ".uart")
    out["baud"] = _int(lk, "baud", 300, 4000000, f + ".baud")
    # the UART's receive ring: by default 100 ms of the line at full speed
    # (the loop's longest pause is a flash write), at least 256 bytes: 1152
    # for a SeaTrac at 115200 baud, 256 for an Iridium modem at 19200
    out["rxbuf"] = _int(lk, "rxbuf", 64, 65536, f + ".rxbuf", max(256, out["baud"] // 100))
    out["tx"] = _pin(lk, "tx", f + ".tx")
    out["rx"] = _pin(lk, "rx", f + ".rx")
    out["address"] = _int(lk, "address", 0, 255, f + ".address", node_id)
    out["medium"] = _str(lk, "medium", f + ".medium", 16, name)
    opts = _dict(lk, "link", f + ".link", {})
    for k in opts:
        if k not in _LINK_OPTIONS:
            _fail(f + ".link", "Link options among " + ", ".join(_LINK_OPTIONS), k)
    out["link"] = dict(opts)
    out["options"] = dict(_dict(lk, "options", f + ".options", {}))
    for k in lk:
        if k not in out:
            _fail(f, "known fields only", k)
    return out


def _auth(a):
    # the network key (acomm.frame.auth) as hex; a wrong one is named but never
    # echoed, since error messages reach consoles and logs
    if a is None:
        return None
    if not isinstance(a, dict):
        _fail("auth", "a dict or None", a)
    key = a.get("key")
    try:
        raw = bytes.fromhex(key) if isinstance(key, str) else None
    except ValueError:
        raw = None
    if raw is None or not 16 <= len(raw) <= 64:
        raise ConfigError("board config: auth.key: 16 to 64 bytes written as hex (32 to 128 digits); "
                          "the value given is not (not shown)")
    out = {"key": raw, "tag_len": _int(a, "tag_len", 4, 16, "auth.tag_len", 4),
           "reserve": _int(a, "reserve", 1, 65536, "auth.reserve", 64)}
    for k in a:
        if k not in out:
            _fail("auth", "known fields only", k)
    return out


def _routing(r):
    # learned routes (acomm.transport.routing): False/None (absent), True or a dict of its options;
    # the names in a tuple literal, not a module-level table: a constant in the bytecode costs a
    # frozen board no heap, and a dict of ranges cost the buoy's boot 1.5 KB (heap_min_frozen_cortex_m)
    if r is None or r is False:
        return None
    if r is True:
        return True
    if not isinstance(r, dict):
        _fail("routing", "True, False or a dict of Routing options", r)
    out = {}
    for k in r:
        if k == "media":
            m = r[k]
            if not isinstance(m, (list, tuple)) or not m or not all(isinstance(x, str) and x for x in m):
                _fail("routing.media", "a non-empty list of link media or names", m)
            out[k] = tuple(m)
        else:
            for name, lo, hi in (("capacity", 1, 254), ("tries", 1, 10), ("search_ms", 1000, 3600000),
                                 ("hold_ms", 0, 86400000), ("lifetime_ms", 1000, 86400000),
                                 ("jitter_ms", 0, 600000), ("seed", 0, 0x7FFFFFFF), ("ring", 0, 62)):
                if k == name:
                    out[k] = _int(r, k, lo, hi, "routing." + k)
                    break
            else:
                _fail("routing", "Routing options among media, capacity, tries, search_ms, hold_ms, "
                      "lifetime_ms, jitter_ms, seed, ring", k)
    return out


def _web(w):
    # the operator console (acomm_web.board; never loaded without this)
    if w is None:
        return None
    if not isinstance(w, dict):
        _fail("web", "a dict or None", w)
    pw = w.get("password")
    if pw is not None and (not isinstance(pw, str) or not 1 <= len(pw) <= 64):
        _fail("web.password", "None or a string of 1..64 characters", pw)
    for k in w:
        if k not in ("host", "port", "password", "log_size", "max_streams"):
            _fail("web", "host, port, password, log_size, max_streams", k)
    return {"host": _str(w, "host", "web.host", 39, "127.0.0.1"), "port": _int(w, "port", 1, 65535, "web.port", 80),
            "password": pw, "log_size": _int(w, "log_size", 4, 40, "web.log_size", 16),
            "max_streams": _int(w, "max_streams", 1, 8, "web.max_streams", 2)}


def _gps(g):
    # a GPS receiver's UART (acomm.drivers.gps reads its time); the same
    # fields as a link's UART
    if g is None:
        return None
    if not isinstance(g, dict):
        _fail("gps", "a dict or None", g)
    for k in g:
        if k not in ("uart", "baud", "tx", "rx", "rxbuf"):
            _fail("gps", "uart, baud, tx, rx, rxbuf", k)
    return {"uart": _int(g, "uart", 0, 9, "gps.uart"), "baud": _int(g, "baud", 300, 4000000, "gps.baud", 9600),
            "tx": _pin(g, "tx", "gps.tx"), "rx": _pin(g, "rx", "gps.rx"),
            "rxbuf": _int(g, "rxbuf", 64, 65536, "gps.rxbuf", 256)}


def check(cfg):
    if not isinstance(cfg, dict):
        _fail("CONFIG", "a dict", cfg)
    out = {}
    out["name"] = _str(cfg, "name", "name")
    out["node_id"] = node_id = _int(cfg, "node_id", 1, 254, "node_id")
    arch = cfg.get("arch")
    if arch not in ARCHES:
        _fail("arch", "one of " + ", ".join(ARCHES), arch)
    out["arch"] = arch
    lines = cfg.get("mpy_lines", True)
    if lines is not True and lines is not False:
        _fail("mpy_lines", "True or False", lines)
    if not lines:  # absent otherwise: the checked config stays as it was
        out["mpy_lines"] = False
    peers = _dict(cfg, "peers", "peers", {})
    for k in peers:
        v = peers[k]
        if not isinstance(k, str) or not 1 <= len(k) <= 16:
            _fail("peers", "names of 1..16 characters", k)
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 254 or v == node_id:
            _fail("peers." + k, "a node id 1..254 other than node_id", v)
    out["peers"] = dict(peers)
    routes = _dict(cfg, "routes", "routes", {})
    for k in routes:
        if k not in peers:
            _fail("routes", "destinations among the peers", k)
        if routes[k] not in peers:
            _fail("routes." + k, "a next hop among the peers", routes[k])
    out["routes"] = dict(routes)
    rt = _routing(cfg.get("routing"))
    if rt is not None:  # absent otherwise: a board that does not route keeps the checked config it had
        out["routing"] = rt
    st = cfg.get("storage")
    if st is not None:
        if not isinstance(st, dict):
            _fail("storage", "a dict or None", st)
        st = {
            "path": _str(st, "path", "storage.path", 64),
            "capacity": _int(st, "capacity", 1024, 1 << 24, "storage.capacity"),
            "max_record": _int(st, "max_record", 16, 65535, "storage.max_record", 256),
        }
    out["storage"] = st
    out["max_packet"] = _int(cfg, "max_packet", 64, 65536, "max_packet", 4096)
    wd = _int(cfg, "watchdog_ms", 0, 60000, "watchdog_ms", 0)
    if 0 < wd < 500:
        _fail("watchdog_ms", "0 or 500..60000", wd)
    out["watchdog_ms"] = wd
    out["step_ms"] = _int(cfg, "step_ms", 1, 1000, "step_ms", 10)
    out["gc_ms"] = _int(cfg, "gc_ms", 10, 60000, "gc_ms", 1000)
    out["idle_ms"] = _int(cfg, "idle_ms", 1, 10000, "idle_ms", 100)
    if out["idle_ms"] < out["step_ms"]:
        _fail("idle_ms", "step_ms..10000", out["idle_ms"])
    links = cfg.get("links")
    if not isinstance(links, (list, tuple)) or not links:
        _fail("links", "a non-empty list of link dicts", links)
    names = []
    out["links"] = [_link(i, lk, node_id, names) for i, lk in enumerate(links)]
    sta = cfg.get("station")
    if sta is not None:
        if not isinstance(sta, dict):
            _fail("station", "a dict or None", sta)
        s = {}
        for key in ("report_to", "alarm_to"):
            v = sta.get(key)
            if v is not None and v not in peers:
                _fail("station." + key, "a peer name", v)
            s[key] = v
        s["report_period_s"] = _int(sta, "report_period_s", 0, 86400, "station.report_period_s", 0)
        sta = s
    out["station"] = sta
    out["auth"] = _auth(cfg.get("auth"))
    g = _gps(cfg.get("gps"))
    if g is not None:  # absent otherwise, as web
        if g["uart"] in [lk["uart"] for lk in out["links"]]:
            _fail("gps.uart", "a UART no link uses", g["uart"])
        out["gps"] = g
    w = _web(cfg.get("web"))
    if w is not None:  # absent otherwise: the buoy's checked config stays as it was
        out["web"] = w
    for k in cfg:
        if k not in out and k not in ("web", "mpy_lines", "routing", "gps"):
            _fail("CONFIG", "known fields only", k)
    return out
