# The console on a MicroPython board (a diver's tablet with Wi-Fi): what
# acomm_mp.start runs instead of its plain loop when the board's config has
# a `web` field. One asyncio loop runs the node (acomm_mp.runasync.run), the
# console's poll and the microdot server; no thread, no lock. The network
# must be up already (boot.py joins the Wi-Fi: that is the board's own).
#
# On the buoy nothing imports this module: its config has no `web`.


def serve(board, web, stop=None):
    """Runs the board's node and its console for ever (until stop() is true). web: the checked config field."""
    import asyncio

    from acomm.apps.console import ConsoleState
    from acomm.compat import ticks_ms
    from acomm_mp.runasync import run

    from .server import WebConsole, tee

    node = board.node
    state = ConsoleState(node, log_size=web["log_size"])
    tee(node, state)
    wc = WebConsole(state, password=web["password"], max_streams=web["max_streams"])

    async def poll():
        while stop is None or not stop():
            state.poll(ticks_ms())
            await asyncio.sleep(0.5)

    async def main():
        server = asyncio.create_task(wc.app.start_server(web["host"], web["port"]))
        asyncio.create_task(poll())
        print("acomm %s: console on http://%s:%d/" % (node.name, web["host"], web["port"]))
        await run(board, stop=stop)
        wc.app.shutdown()
        await server

    asyncio.run(main())
    return wc
