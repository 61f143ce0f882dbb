# A relay's lost custody (EV_RELAY_STATUS) reaches a person and a Python program: the node
# console prints a line for it (JSON and text) and eventview gives it named fields. Before, the
# console's as_dict returned None for the code, so the only report of a packet that expired in a
# relay's store showed nowhere. The scenario is the core test's (tests/core/test_transport.py):
# the buoy moves out of range while the auv holds the diver's packet, and its lifespan runs out.
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "core"))

from acomm.events import EV_RELAY_STATUS, TRANSMITTED  # noqa: E402
from acomm.prng import Prng  # noqa: E402
from acomm_cpython.console.eventlines import as_dict, as_text  # noqa: E402
from acomm_cpython.eventview import RelayStatus, view  # noqa: E402
from transportnet import net, statuses  # noqa: E402


def _relay_event():
    w, a, b, c, ta = net(relay=True)
    pid = ta.send(w.now(), "buoy", Prng(9).bytes(60), 240, 5)
    assert w.run(600000, until=lambda: TRANSMITTED in statuses(a, pid))
    w.channel.set_position(1, 50000.0, 0.0, 0.0)
    relay = lambda: [e for e in c.events if e[0] == EV_RELAY_STATUS]  # noqa: E731
    assert w.run(600000, until=relay)
    return pid, relay()[0]


def test_the_console_shows_a_packet_that_expired_in_this_relays_custody():
    pid, ev = _relay_event()
    d = as_dict(ev)
    assert d == {"event": "relay_status", "origin": "diver", "id": pid, "status": "expired",
                 "reason": "lifespan over", "final": True}, d
    assert as_text(d) == "relayed packet %d from diver expired here: lifespan over" % pid


def test_the_named_view_of_a_relay_status():
    pid, ev = _relay_event()
    v = view(ev)
    assert isinstance(v, RelayStatus) and v.kind == "relay_status"
    assert (v.origin, v.packet_id, v.status_name, v.reason, v.final) == ("diver", pid, "expired", "lifespan over", True)
    assert v.raw is ev
