# A core Node driven by an asyncio event loop, so that an idle node sleeps.
#
# The node is sans-IO: node.step(now) reads its streams, polls its links and
# transport and writes what they produced. Instead of calling it every few
# milliseconds, NodeLoop calls it
#   - when a descriptor of one of the node's ports is readable (the ports
#     name them with filenos(): serial ports, TCP and UDP sockets), so a
#     frame's bytes reach the driver as soon as the kernel has them;
#   - when something asks (wake(): a request was queued);
#   - on a timer set after each step from what the node still has to do:
#     BUSY_MS while a frame is on the air, a reply or an ack is awaited,
#     requests are queued or bytes wait to go; PENDING_MS while transport
#     packets wait (their timers are seconds long); IDLE_MS otherwise.
# An idle node therefore runs 1000 / IDLE_MS steps a second; the timers of
# an idle link (adverts, availability loss, a driver's command timeout) fire
# at most IDLE_MS late, which on links whose frames take seconds is noise.
# A port without descriptors (a pyserial rfc2217:// URL) is polled at
# BUSY_MS.

from __future__ import annotations

import asyncio
import select
from typing import Any, Callable, List, Optional, Sequence, Set

BUSY_MS = 10
PENDING_MS = 100
IDLE_MS = 250


def next_wake_ms(node: Any, ports: Sequence[Any], now: int) -> int:
    """How long the node may sleep after a step at `now` before its next step is due (ms), by what
    it has to do (a port without descriptors is NodeLoop's to poll)."""
    for link in node.links.values():
        if len(link.queue) or not link.idle(now):
            return BUSY_MS
    for p in ports:
        pending = getattr(p, "pending", None)
        if pending is not None and pending():
            return BUSY_MS
    t = node.transport
    if t is not None and t.pending():
        return PENDING_MS
    return IDLE_MS


class NodeLoop:
    """Steps `node` on the running asyncio loop when its ports have bytes, when woken, and on its
    next deadline. ports: the node's streams and frame ports (anything with filenos()); step:
    what one round is (default node.step; it may return the time or None).

    after(now) callbacks run after every step (the library's futures, a console). A step that
    raises is reported once per exception type to the loop's exception handler (or on_error)
    and the node keeps running, as a board does."""

    def __init__(self, node: Any, ports: Sequence[Any] = (), on_error: Optional[Callable[[BaseException], None]] = None,
                 step: Optional[Callable[[], Any]] = None):
        self.node = node
        # one round of work: node.step, or what wraps it (a board's tick with
        # its applications' timers, a web console's lock)
        self._step_fn: Callable[[], Any] = step if step is not None else node.step
        self.ports: List[Any] = list(ports)
        self.after: List[Callable[[int], None]] = []
        self.on_error = on_error
        self.steps = 0
        self.step_errors = 0
        self._loop: Optional[asyncio.AbstractEventLoop] = None
        self._fds: Set[int] = set()  # descriptors with a reader on the loop
        self._held: Set[int] = set()  # readers resting until the next timed step (_readable)
        self._timer: Optional[asyncio.TimerHandle] = None
        self._soon = False
        self._reported: Set[type] = set()
        self._running = False

    # -- life -----------------------------------------------------------------------
    def start(self) -> "NodeLoop":
        """Starts stepping on the running loop (call from a coroutine); -> self."""
        self._loop = asyncio.get_running_loop()
        self._running = True
        self.wake()
        return self

    def close(self) -> None:
        """Stops stepping: no more readers or timers (the ports stay open: their owner closes them)."""
        self._running = False
        if self._loop is not None:
            for fd in list(self._fds):
                self._loop.remove_reader(fd)
        self._fds.clear()
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def add_port(self, port: Any) -> None:
        """One more port to wait on (a link added after start)."""
        self.ports.append(port)
        self.wake()

    def wake(self) -> None:
        """Asks for a step as soon as the loop is free (several asks make one step)."""
        if self._running and not self._soon and self._loop is not None:
            self._soon = True
            self._loop.call_soon(self._step)

    # -- the step -------------------------------------------------------------------
    def _readable(self, fd: int) -> None:
        self._step()
        # A descriptor still readable right after a step was not drained: a
        # port that hung up (a pty whose other end closed stays readable
        # with nothing to read) or more than a step reads. Its reader rests
        # until the next timed step, so neither can spin the loop.
        if fd not in self._fds or self._loop is None:
            return
        try:
            again = bool(select.select([fd], [], [], 0)[0])
        except (OSError, ValueError):
            again = True  # closed under us: the next sync drops it
        if again:
            self._loop.remove_reader(fd)
            self._fds.discard(fd)
            self._held.add(fd)
            self._arm(BUSY_MS)

    def _step(self) -> None:
        self._soon = False
        if not self._running:
            return
        node = self.node
        try:
            now = self._step_fn()
            if now is None:
                now = node.clock()
            self.steps += 1
            for fn in list(self.after):
                fn(now)
            wait = next_wake_ms(node, self.ports, now)
        except Exception as e:  # noqa: BLE001 - as on a board: the node keeps running
            self.step_errors += 1
            self._report(e)
            wait = BUSY_MS
        if self._sync_readers():
            wait = min(wait, BUSY_MS)  # a port the loop cannot wait on is polled
        self._arm(wait)

    def _report(self, e: BaseException) -> None:
        if type(e) in self._reported:
            return  # once per kind: a fault that repeats every step must not flood
        self._reported.add(type(e))
        if self.on_error is not None:
            self.on_error(e)
        elif self._loop is not None:
            self._loop.call_exception_handler({"message": "acomm node step failed (the node carries on)",
                                               "exception": e})

    def _arm(self, wait_ms: int) -> None:
        assert self._loop is not None
        when = self._loop.time() + wait_ms / 1000
        t = self._timer
        if t is not None:
            if t.when() <= when:
                return  # an earlier step is already due
            t.cancel()
        self._timer = self._loop.call_at(when, self._timed)

    def _timed(self) -> None:
        self._timer = None
        self._held.clear()
        self._step()

    def _sync_readers(self) -> bool:
        # the descriptors come and go (a TCP modem reconnects, a client
        # joins a server): register what the ports name now; -> whether a
        # port has none at all (filenos() None: polled)
        loop = self._loop
        assert loop is not None
        want: Set[int] = set()
        polled = False
        for p in self.ports:
            fds = p.filenos()
            if fds is None:
                polled = True
            else:
                want.update(fds)
        for fd in self._fds - want:
            loop.remove_reader(fd)
            self._fds.discard(fd)
        for fd in want - self._fds - self._held:
            loop.add_reader(fd, self._readable, fd)
            self._fds.add(fd)
        return polled


async def run_nodes(nodes: Sequence[Any], seconds: Optional[float] = None,
                    until: Optional[Callable[[], bool]] = None) -> bool:
    """Runs each (node, ports) pair on its own NodeLoop until until() is true after a step (-> True)
    or `seconds` pass (-> False); with neither, for ever. For scripts and tests with several
    nodes in one program (the simulator steps nodes on virtual time instead)."""
    done = asyncio.Event()

    def check(now: int) -> None:
        if until is not None and until():
            done.set()

    loops = [NodeLoop(node, ports) for node, ports in nodes]
    for nl in loops:
        nl.after.append(check)
        nl.start()
    try:
        await asyncio.wait_for(done.wait(), seconds)
        return True
    except asyncio.TimeoutError:
        return False
    finally:
        for nl in loops:
            nl.close()


def run(nodes: Sequence[Any], seconds: Optional[float] = None, until: Optional[Callable[[], bool]] = None) -> bool:
    """run_nodes on a fresh event loop, blocking (see run_nodes)."""
    return asyncio.run(run_nodes(nodes, seconds, until))
