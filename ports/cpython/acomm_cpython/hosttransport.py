# The transport as a topside program uses it: the core's Transport plus
# what only a host asks of it, cancelling one of its own packets and
# reading a transfer's progress. Both need the transport's private state;
# they live here, on CPython, because every method on the core class costs
# the buoy's .mpy build heap it does not have (docs/micropython-port.md),
# and a board has no user to cancel a file or watch a progress bar.
# Everything here reads that state in this one place, never changes it
# except through the transport's own steps.

from __future__ import annotations

from typing import Any, Optional, Tuple

from acomm.events import CANCELED
from acomm.transport import Transport


def cancel(t: Transport, now: int, pid: int, reason: str = "canceled") -> bool:
    """Ends the transport t's own pending packet pid: its fragments leave the link queues, its
    record leaves the store and one final EV_PACKET_STATUS (canceled) follows. False when pid is
    not one of t's own pending packets (already final, or unknown)."""
    t_: Any = t  # its private state, read in this module only
    for p in t_._out:
        if p.pid == pid and not p.relayed:
            for c in list(p.group) if p.group is not None else [p]:
                t_._drop(now, c)
            t_.packets.delete(p)
            t_.stats["canceled"] = t_.stats.get("canceled", 0) + 1
            t_._status(p, CANCELED, reason)
            return True
    return False


def progress(t: Transport, pid: int) -> Optional[Tuple[int, int, int]]:
    """(fragments sent, fragments acknowledged, fragments in all) of the transport t's own pending
    packet pid; None before its transfer starts (or once it is final). sent counts the
    acknowledged ones plus those of the current round handed to the link; the receiver's SACKs
    come at the end of each round."""
    t_: Any = t
    for p in t_._out:
        o = p.out
        if p.pid != pid or o is None or p.relayed:
            continue
        acked = sum(1 for a in o.acked if a)
        return min(o.count, acked + (0 if o.probing else o.sent_in_round)), acked, o.count
    return None


class HostTransport(Transport):
    """acomm.transport.Transport with cancel() and progress() as methods (CPython only)."""

    def cancel(self, now: int, pid: int, reason: str = "canceled") -> bool:
        """See cancel(t, now, pid, reason)."""
        return cancel(self, now, pid, reason)

    def progress(self, pid: int) -> Optional[Tuple[int, int, int]]:
        """See progress(t, pid)."""
        return progress(self, pid)
