# What the console costs a MicroPython heap, step by step (gc.mem_alloc
# after gc.collect): its state's code (acomm.apps.console), microdot, the
# server module, an empty ConsoleState, the Microdot app with its routes,
# and the state filled to its bounds (a full log, every alarm slot, an hour
# of quality buckets), and then what each open event stream holds between
# its pushes, once it has sent its first views (web_heap_per_stream; not in
# the total). The
# node and the CADDY catalog are loaded first: the tablet has them anyway.
# Prints one JSON line per figure; `acomm bench web` runs it under the
# MicroPython unix port (modules from source and as .mpy) and the i386
# firmware build (acomm frozen in).
#
#   micropython -m acomm_web.heap        (MICROPYPATH: acomm, ports/web, microdot)
import gc


def _used():
    gc.collect()
    gc.collect()
    return gc.mem_alloc()


class _Link:
    # what a received event's link gives the console: its name
    name = "acoustic"


def measure():
    """[(name, bytes)] of each step."""
    # the tablet runs a node already, and its station speaks CADDY
    from acomm.catalog import caddy
    from acomm.node import Node

    out = []
    a0 = _used()
    import acomm.apps.console as con

    a1 = _used()
    import microdot  # noqa: F401
    import microdot.sse  # noqa: F401

    a2 = _used()
    from acomm_web.server import WebConsole

    a3 = _used()
    node = Node("tablet", 2)
    node.names.add("buoy", 1)
    a3n = _used()
    state = con.ConsoleState(node)
    a4s = _used()
    web = WebConsole(state, max_streams=2)
    a4 = _used()
    link = _Link()
    alarm = caddy.CATALOG.pack([(caddy.ALARM, {"alarm": "low_air"})])
    chat = caddy.CATALOG.pack([(caddy.CHAT, {"text": "t04.30 depth 10.0m air 185 hr 87"})])
    for k in range(con.LOG_SIZE):
        state.on_event((21, link, "buoy", "tablet", alarm if k < con.ALARM_SIZE else chat), k * 1000)
    for k in range(con.BUCKETS):
        state._status(k * 60000, "acoustic", k, 1, "")
        state._status(k * 60000 + 500, "acoustic", k, 5, "")
    a5 = _used()
    out.append(("web_heap_console_code", a1 - a0))
    out.append(("web_heap_microdot", a2 - a1))
    out.append(("web_heap_server_code", a3 - a2))
    out.append(("web_heap_state_empty", a4s - a3n))
    out.append(("web_heap_app", a4 - a4s))
    out.append(("web_heap_state_full", a5 - a4))
    out.append(("web_heap_total", (a3 - a0) + (a5 - a3n)))
    out.append(("web_heap_per_stream", _per_stream(web)))
    web = state = None
    return out


def _per_stream(web, n=2, port=18765, rounds=2, samples=4):
    # What each open event stream holds, its first views sent: the heap's
    # level with n streams open from this same process, minus its level
    # with n idle connections to the same server (so the client's own
    # socket objects cancel out). The collector is conservative: a stale
    # pointer on the stack can keep a freed buffer (14 KB, seen) alive for a
    # whole sample run, and a figure of one run each flipped sign when an
    # unrelated module changed. So a first run of streams allocates what is
    # allocated once (not counted), the two kinds then alternate `rounds`
    # times, and each level is the least of all its samples. (The figure
    # also moved because the connections were never closed: on MicroPython
    # a stream's close() does nothing and wait_closed() closes the socket,
    # so each run left ~3.5 KB behind and the levels climbed run by run.)
    import asyncio

    low = {}

    async def open_conns(events):
        conns = []
        for _ in range(n):
            r, w = await asyncio.open_connection("127.0.0.1", port)
            if events:
                w.write(b"GET /api/events HTTP/1.1\r\nHost: h\r\n\r\n")
                await w.drain()
            conns.append((r, w))
        await asyncio.sleep(0.6)  # the streams send their first views (the idle ones wait)
        return conns

    async def drain(conns):
        for r, w in conns:
            try:
                await asyncio.wait_for(r.read(65536), 0.05)
            except asyncio.TimeoutError:
                pass

    async def main():
        server = asyncio.create_task(web.app.start_server("127.0.0.1", port))
        await asyncio.sleep(0.3)
        for k, events in enumerate((True,) + (False, True) * rounds):
            conns = await open_conns(events)
            # what the streams hold between their pushes, not a push in flight
            for _ in range(samples):
                await drain(conns)
                u = _used()
                if k and (events not in low or u < low[events]):
                    low[events] = u
                await asyncio.sleep(0.15)
            for r, w in conns:
                w.close()
                await w.wait_closed()  # MicroPython's close() leaves the socket open
            await asyncio.sleep(0.3)
        web.app.shutdown()
        await server

    asyncio.run(main())
    return (low[True] - low[False]) // n


def main():
    for name, value in measure():
        print('{"name": "%s", "value": %d, "unit": "B"}' % (name, value))


main()
