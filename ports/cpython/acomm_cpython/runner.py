# Running Nodes on real time with asyncio (the simulator steps them on
# virtual time instead). One task steps every node, each with its own clock
# (acomm.compat.ticks_ms by default), then sleeps period_ms; other asyncio
# tasks (a console, a bridge) run in between.

import asyncio


async def run_nodes(nodes, seconds=None, until=None, period_ms=5):
    # Steps `nodes` (a Node or a list of them) until until() returns True
    # (-> True) or `seconds` have passed (-> False). With neither, forever.
    if not isinstance(nodes, (list, tuple)):
        nodes = (nodes,)
    loop = asyncio.get_running_loop()
    deadline = None if seconds is None else loop.time() + seconds
    period = period_ms / 1000
    while True:
        for n in nodes:
            n.step()
        if until is not None and until():
            return True
        if deadline is not None and loop.time() >= deadline:
            return False
        await asyncio.sleep(period)


def run(nodes, seconds=None, until=None, period_ms=5):
    # Blocking form for scripts and tests: a fresh event loop per call.
    return asyncio.run(run_nodes(nodes, seconds, until, period_ms))
