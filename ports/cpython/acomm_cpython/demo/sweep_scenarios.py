# The networks `acomm sweep` runs: each scenario takes a dict of parameters,
# a seed and simulated minutes, runs the real stack in the simulated ocean
# and returns what one run measured (one CSV row). A run depends only on
# its arguments, so it gives the same row in any process on any worker.
#
#   demo  the demo mission (acomm demo: buoy, diver, AUV on SeaTrac beacons,
#         CADDY cycle, telemetry, dive log, alarm, teleop, ship outage)
#         with `loss` (a fixed loss probability added to its loss curve)
#         and `mac` (tdma: the demo's schedules; aloha: random backoff of up
#         to 10 s instead; none: the modems' own timing)
#   grid  `nodes` on a square grid `range` metres apart, on `modem` (bpsk or
#         fhss, seed 004's packet modems), each sending a 20-byte one-way
#         frame to its grid neighbour `rate` times a minute, under `mac`
#         (aloha: backoff up to 8 airtimes; tdma: one slot per node; none),
#         with a loss curve that grows with range (2 % at 0 m, 10 % at
#         500 m, certain at 1000 m) and a fixed `loss` on top; with
#         `routing` learned, flooding or oracle instead of none, the routed
#         grid of `acomm bench routing` (acomm_sim.routednet: `nodes`
#         rounded down to a square, 150 m apart, heard only within 200 m,
#         numbered packets between random pairs across it, routed that way;
#         range, mac, rate, modem and loss are then its own)
#   chain, random  acomm_sim.routednet's chain (6 nodes, 5 hops) and random
#         scenario (64 nodes at random and two AUVs crossing), `routing`
#         learned, flooding or oracle
#
# Measures (traffic the applications sent, as acomm_sim.metrics.PacketLog
# counts it): pdr, latency quantiles (p50, p90, p99, s), jitter (seed
# 004's mean |L_k - L_(k-1)|, s), collisions (copies lost to overlapping
# arrivals), goodput (application bytes delivered per simulated second),
# overhead (routed scenarios: route control bytes on the air over payload
# bytes delivered; empty for the others).

SCENARIOS = {
    "demo": {"loss": 0.0, "mac": "tdma"},
    "grid": {"nodes": 16, "range": 300.0, "loss": 0.0, "mac": "aloha", "rate": 1.0, "modem": "bpsk",
             "routing": "none"},
    "chain": {"routing": "learned"},
    "random": {"routing": "learned"},
}

MEASURES = ("sent", "received", "pdr", "latency_p50_s", "latency_p90_s", "latency_p99_s", "jitter_s",
            "collisions", "goodput_Bps", "overhead")

GRID_LOSS_CURVE = ((0.0, 0.02), (500.0, 0.1), (1000.0, 1.0))

# With a scenario file (acomm sweep --site FILE), the demo and grid scenarios
# run on its physics channel, and these grid parameters change its site:
# grid name -> acomm_sim.site parameter. The file's content rides in each
# run's parameters as "site" (a dict, so that runs stay picklable).
SITE_PARAMS = {"wind": "wind_mps", "shipping": "shipping", "depth": "depth_m", "temperature": "temperature_c",
               "salinity": "salinity_psu", "spreading": "spreading_k", "bottom_loss": "bottom_loss_db"}
GRID_PAYLOAD = 20


def parse_value(name, text, scenario):
    # a grid value of the command line in the type of the parameter's default
    if name in SITE_PARAMS:
        return float(text)
    default = SCENARIOS[scenario][name]
    if isinstance(default, float):
        return float(text)
    if isinstance(default, int):
        return int(text)
    return text


def run(scenario, params, seed, minutes):
    """One run -> {measure: value} (MEASURES); raises what the run raised."""
    p = dict(SCENARIOS[scenario])
    p.update(params)
    if p.get("site") is not None and scenario not in ("demo", "grid"):
        raise ValueError("%s: a scenario file (--site) goes with the demo and grid scenarios" % scenario)
    if scenario == "demo":
        return _demo(p, seed, minutes)
    if scenario == "grid" and p["routing"] == "none":
        return _grid(p, seed, minutes)
    if scenario in ("grid", "chain", "random"):
        return _routed(scenario, p, seed, minutes)
    raise ValueError("unknown scenario %r" % (scenario,))


def _quantile(xs, q):
    # nearest rank on sorted xs
    if not xs:
        return None
    k = int(q * len(xs) + 0.5) - 1
    return xs[min(len(xs) - 1, max(0, k))]


def measures(log, collisions, sim_s):
    rows = [log.rows[p] for p in log.order]
    lat = [r[7] - r[6] for r in rows if r[7] is not None]
    steps = [abs(lat[i] - lat[i - 1]) for i in range(1, len(lat))]
    ordered = sorted(lat)

    def s(ms):
        return None if ms is None else round(ms / 1000, 4)

    return {
        "sent": len(rows),
        "received": len(lat),
        "pdr": round(len(lat) / len(rows), 6) if rows else None,
        "latency_p50_s": s(_quantile(ordered, 0.5)),
        "latency_p90_s": s(_quantile(ordered, 0.9)),
        "latency_p99_s": s(_quantile(ordered, 0.99)),
        "jitter_s": s(sum(steps) / len(steps)) if steps else None,
        "collisions": collisions,
        "goodput_Bps": round(sum(r[5] for r in rows if r[7] is not None) / sim_s, 4) if sim_s else None,
        "overhead": None,
    }


# -- routed networks (chain, random, grid with routing) -------------------------------

def _routed(scenario, p, seed, minutes):
    from acomm_sim.routednet import MAX_NODES, MODES, RoutedNet

    mode = p["routing"]
    if mode not in MODES:
        raise ValueError("%s: routing is %s, not %r" % (scenario, ", ".join(MODES + (("none",) if scenario == "grid"
                                                                                       else ())), mode))
    nodes = None
    if scenario == "grid":
        nodes = int(p["nodes"])
        if not 4 <= nodes <= MAX_NODES:
            raise ValueError("grid: nodes is 4..%d with routing" % MAX_NODES)
    net = RoutedNet(scenario, mode, seed, nodes=nodes)
    # the bench's drain, within the minutes asked for: a fifth of them with no new packet
    m = net.run(minutes * 0.8, minutes * 0.2)
    lat = sorted(net.got.values())
    steps = [abs(lat[i] - lat[i - 1]) for i in range(1, len(lat))]

    def q(x):
        v = _quantile(lat, x)
        return None if v is None else round(v / 1000, 4)

    sim_s = net.w.now() / 1000
    return {"sent": m["sent"], "received": m["delivered"], "pdr": round(m["pdr"], 6) if m["sent"] else None,
            "latency_p50_s": q(0.5), "latency_p90_s": q(0.9), "latency_p99_s": q(0.99),
            "jitter_s": round(sum(steps) / len(steps) / 1000, 4) if steps else None,
            "collisions": net.ch.collided,
            "goodput_Bps": round(net.delivered_bytes / sim_s, 4) if sim_s else None,
            "overhead": round(m["overhead_ratio"], 4) if m["overhead_ratio"] is not None else None}


# -- demo ---------------------------------------------------------------------------

def _demo(p, seed, minutes):
    from .mission import MACS, Mission

    mac = p["mac"]
    if mac not in MACS:
        raise ValueError("demo: mac is tdma, aloha or none, not %r" % (mac,))
    m = Mission(seed=seed, minutes=minutes, mac=mac, uplink=False, scenario=_scenario(p))  # the sweep compares the water's MACs
    m.channel.loss = float(p["loss"])
    m.run()
    return measures(m.traffic.log, m.channel.collided, m.world.now() / 1000)


# -- grid -----------------------------------------------------------------------------

class _Sender:
    # a world task: node `sn` sends a numbered one-way frame to `dst` every
    # period_ms, from offset_ms on
    def __init__(self, traffic, sn, dst, period_ms, offset_ms, lifespan_s):
        self.traffic = traffic
        self.sn = sn
        self.dst = dst
        self.period_ms = period_ms
        self.next = offset_ms
        self.lifespan_s = lifespan_s
        self.n = 0

    def poll(self, now):
        if now >= self.next:
            head = ("%s:%d:" % (self.sn.name, self.n)).encode()
            data = (head + b"." * GRID_PAYLOAD)[:GRID_PAYLOAD]
            self.traffic.send(self.sn, self.dst, data, "data", self.lifespan_s, 5, False, now)
            self.n += 1
            self.next += self.period_ms
        return self.next


def _grid(p, seed, minutes):
    from acomm.drivers.mac import Aloha, Tdma
    from acomm_sim.channel import Channel
    from acomm_sim.packetmodem import PROFILES
    from acomm_sim.world import World

    from .traffic import Traffic

    n = int(p["nodes"])
    if not 2 <= n <= 254:
        raise ValueError("grid: nodes is 2..254")
    modem = p["modem"]
    if modem not in PROFILES:
        raise ValueError("grid: modem is one of %s" % ", ".join(sorted(PROFILES)))
    mac = p["mac"]
    if mac not in ("tdma", "aloha", "none"):
        raise ValueError("grid: mac is tdma, aloha or none, not %r" % (mac,))
    rate = float(p["rate"])
    if rate <= 0:
        raise ValueError("grid: rate is frames per node and minute, > 0")
    spacing = float(p["range"])
    bitrate, overhead, _ = PROFILES[modem]
    air = ((GRID_PAYLOAD + 5 + overhead) * 8000 + bitrate - 1) // bitrate
    side = 1
    while side * side < n:
        side += 1
    sc = _scenario(p)
    if sc is None or sc.channel == "curve":
        ch = Channel(seed=seed, loss=float(p["loss"]), loss_curve=GRID_LOSS_CURVE)
    else:
        from acomm_sim.physchannel import PhysicsChannel

        ch = PhysicsChannel(sc.site, seed=seed, loss=float(p["loss"]))
    w = World(seed=seed, channel=ch)
    prop = int(spacing * 1.5 * 1000 / ch.sound_speed)
    slots = [(i + 1, air + prop + 400, 200) for i in range(n)]
    traffic = Traffic("acoustic")
    for i in range(n):
        if mac == "tdma":
            m = Tdma(slots, i + 1, tx_ms=air)
        elif mac == "aloha":
            m = Aloha(8 * air, seed=seed * 1000 + i)
        else:
            m = None
        w.add("n%d" % (i + 1), i + 1, modem, position=(spacing * (i % side), spacing * (i // side), 10.0),
              mac=m, link_opts={"advert_period_ms": 600000, "queue_capacity": 8},
              listener=_listener(w, traffic, "n%d" % (i + 1)))
    period = int(60000 / rate)
    names = ["n%d" % (i + 1) for i in range(n)]
    for i in range(n):
        # the next node on its row, or the one before at the row's end
        j = i + 1 if (i + 1) % side and i + 1 < n else i - 1
        sender = _Sender(traffic, w.nodes[names[i]], names[j], period, (i * period) // n, max(60, period // 1000 * 2))
        w.add_task(sender)
    w.run(int(minutes * 60000))
    return measures(traffic.log, ch.collided, w.now() / 1000)


def _scenario(p):
    # the run's scenario file (an acomm_sim.site.Scenario) with the swept
    # site parameters applied, or None without --site
    if p.get("site") is None:
        return None
    from acomm_sim.site import parse

    sc = parse(p["site"])
    sc.site = sc.site.with_(**{SITE_PARAMS[k]: float(v) for k, v in p.items() if k in SITE_PARAMS})
    return sc


def _listener(w, traffic, me):
    # deliveries to the frame's destination count; statuses date the send
    from acomm.events import EV_RECEIVED, EV_STATUS

    def on_event(ev):
        if ev[0] == EV_RECEIVED and ev[3] == me:
            traffic.received(ev[2], me, ev[4], w.now())
        elif ev[0] == EV_STATUS:
            traffic.status(me, ev[2], ev[3], w.now())

    return on_event
