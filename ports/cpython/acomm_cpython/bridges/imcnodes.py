# The acomm side of `acomm bridge imc` (acomm_cpython.cli.bridge): the
# nodes a bridge serves, either a simulated network on the simulator's World
# (build_sim: every node an IMC system, stepped at --speed times real time)
# or one node on real modems (build_real), and the IMC gateway of each node
# (gateways, acomm.apps.imcgateway).

import time

from acomm.apps.imcgateway import ImcGateway
from acomm.compat import ticks_diff, ticks_ms
from acomm.node import Node

from ..modems import add_known, hostport, keyval

_SIM_STEP_MAX_MS = 1000  # simulated ms per loop round at most, so the sockets are read meanwhile


def gateways(args, nodes):
    """An ImcGateway for each node, listening to it, as args (--map, --peer, --imc-id...) say."""
    names = dict(keyval(kv) for kv in args.map)
    static = [hostport(x, "127.0.0.1") for x in args.peer]
    out = []
    for node in nodes:
        gw = ImcGateway(node, args.imc_id + node.node_id, names=names, static=static, lifespan_s=args.lifespan,
                        announce_ms=int(args.announce_period * 1000), ip_clock=ticks_ms)
        node.listen(gw.on_event)
        out.append(gw)
    return out


def _ignore(ev):
    pass


def build_sim(args):
    from acomm_sim.world import World

    specs = [keyval(x) for x in args.sim_node] or [("topside", "1"), ("auv", "2")]
    world = World(seed=args.seed)
    nodes = []
    for i, (name, nid) in enumerate(specs):
        # the gateway is the node's listener (gateways): the world keeps no event list
        sn = world.add(name, int(nid), args.sim_modem, position=(i * args.distance, 0, 5 if i else 0),
                       listener=_ignore)
        nodes.append(sn.node)
    t0 = time.monotonic()
    sim0 = world.now()

    def advance():
        # the simulated ocean keeps up with the wall clock times --speed
        due = int((time.monotonic() - t0) * args.speed * 1000) - ticks_diff(world.now(), sim0)
        if due >= world.step_ms:
            world.run(min(due, _SIM_STEP_MAX_MS))

    return nodes, advance, world


def _modem_link(node, spec):
    # the same drivers and --modem syntax as `acomm node` (acomm_cpython.modems)
    # (the link is named after its medium: TransmissionRequest.comm_mean picks by it)
    from ..modems import add_modem_link

    add_modem_link(node, spec)


def build_real(args):
    if args.name is None or args.id is None or not args.modem:
        raise ValueError("without --sim, give --name, --id and at least one --modem")
    node = Node(args.name, args.id)
    add_known(node, args.known)
    for spec in args.modem:
        _modem_link(node, spec)
    return [node], node.step, None
