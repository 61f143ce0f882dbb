# A console with something to show, the same on every runtime: a buoy (X150
# USBL) and a diver (X110) on a simulated ocean (acomm_sim), a chat line
# delivered, a range, an alarm; the clock then stands still, so every view
# is the same JSON on CPython and on MicroPython. For tests and the heap
# bench, not for boards.
#
#   micropython -m acomm_web.sample PORT    serves it on 127.0.0.1:PORT
#   python -m acomm_web.sample PORT         (MICROPYPATH / PYTHONPATH: acomm,
#                                           ports/sim, ports/web, microdot)
# It prints "serving PORT" when it listens.


def build(seed=3):
    """-> (World, ConsoleState of the buoy) after two simulated minutes."""
    from acomm.apps.console import ConsoleState
    from acomm.catalog import caddy
    from acomm_sim.world import World

    w = World(seed=seed)
    buoy = w.add("buoy", 1, "seatrac", position=(0.0, 0.0, 0.5), emu_opts={"part": 795, "seed": 11},
                 link_opts={"advert_period_ms": 20000})
    diver = w.add("diver", 2, "seatrac", position=(30.0, 40.0, 10.0), emu_opts={"part": 843, "seed": 12},
                  link_opts={"advert_period_ms": 20000})
    state = ConsoleState(buoy.node)
    buoy.node.listen(state.on_event)
    w.run(60000)
    state.poll(w.now())
    state.command(w.now(), {"op": "chat", "dst": "diver", "text": "come up slowly"}, "alice")
    w.run(30000)
    state.command(w.now(), {"op": "range", "dst": "diver"}, "alice")
    w.run(15000)
    diver.node.send("acoustic", "buoy", caddy.CATALOG.pack([(caddy.ALARM, {"alarm": "low_air"})]), 60, 1, True)
    w.run(15000)
    state.poll(w.now())
    return w, state


def main(argv):
    import asyncio

    from acomm_web.server import WebConsole

    port = int(argv[1]) if len(argv) > 1 else 8080
    w, state = build()
    web = WebConsole(state)

    async def serve():
        task = asyncio.create_task(web.app.start_server("127.0.0.1", port))
        await asyncio.sleep(0.2)
        print("serving %d" % port)
        await task

    asyncio.run(serve())


if __name__ == "__main__":
    import sys

    main(sys.argv)
