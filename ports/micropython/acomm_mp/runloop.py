# The node's main loop: one Board.tick() per step_ms. Board.tick() feeds
# the watchdog and collects garbage at safe points.
#
# run_blocking() is what acomm_mp.start runs on a board: a plain loop that
# sleeps what is left of each step. run() is the same loop as an asyncio
# task, for an application whose other tasks (a display, buttons) share
# the loop; asyncio is imported only there, because on a 64 KiB heap its
# module objects cost about 2.3 KiB that a relay has no use for.

from acomm.compat import ticks_diff, ticks_ms


def run_blocking(board, clock=ticks_ms, sleep_ms=None, stop=None):
    """Ticks the board every step_ms until stop() is true (for ever by default)."""
    if sleep_ms is None:
        import time

        sleep_ms = time.sleep_ms
    step = board.cfg["step_ms"]
    while stop is None or not stop():
        t = clock()
        board.tick(t)
        left = step - ticks_diff(clock(), t)
        if left > 0:
            sleep_ms(left)


async def run(board, clock=ticks_ms, stop=None):
    """The same loop as an asyncio task: other tasks run while it sleeps."""
    import asyncio

    s = getattr(asyncio, "sleep_ms", None)
    step = board.cfg["step_ms"]
    while stop is None or not stop():
        board.tick(clock())
        await (s(step) if s is not None else asyncio.sleep(step / 1000))
