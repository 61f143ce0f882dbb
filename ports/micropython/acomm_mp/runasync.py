# The node's main loop as an asyncio task: Board.poll() (acomm_mp.runloop)
# every step_ms, for an application whose other tasks share the loop (the
# browser console of acomm_web.board, a display, buttons). Its own module,
# so that a board running the plain loop (acomm_mp.runloop.run_blocking)
# never loads this code, nor asyncio, from its flash into its heap.

from acomm.compat import ticks_ms


async def run(board, clock=ticks_ms, stop=None):
    """Polls the board every step_ms as an asyncio task until stop() is true; other tasks run while it sleeps."""
    import asyncio

    s = getattr(asyncio, "sleep_ms", None)
    step = board.cfg["step_ms"]
    while stop is None or not stop():
        board.poll(clock())
        await (s(step) if s is not None else asyncio.sleep(step / 1000))
