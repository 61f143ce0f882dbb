# The node's main loop on asyncio: one Board.tick() per step_ms, so other
# tasks of the application (a display, buttons) share the same loop.
# Board.tick() feeds the watchdog and collects garbage at safe points.

import asyncio

from acomm.compat import ticks_ms


def _sleep_ms(ms):
    s = getattr(asyncio, "sleep_ms", None)
    return s(ms) if s is not None else asyncio.sleep(ms / 1000)


async def run(board, clock=ticks_ms, stop=None):
    step = board.cfg["step_ms"]
    while stop is None or not stop():
        board.tick(clock())
        await _sleep_ms(step)
