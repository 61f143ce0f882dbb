# The soak's ledger (acomm_sim.ledger): a packet is lost only when it was
# accepted, never delivered and never reported expired or failed, at its
# origin or, once a relay took custody (`transmitted` at the origin), at
# that relay (EV_RELAY_STATUS).
from acomm.events import DELIVERED, EXPIRED, FAILED, QUEUED, TRANSMITTED
from acomm_sim.ledger import Ledger


def _accept(led, origin, pid):
    seq = led.begin(origin)
    led.status(origin, pid, QUEUED)
    led.sent(seq, origin, pid)
    return seq


def test_a_packet_in_a_relays_custody_is_lost_until_the_relay_reports_it():
    led = Ledger()
    a = _accept(led, 3, 7)
    b = _accept(led, 3, 8)
    c = _accept(led, 3, 9)
    led.status(3, 7, TRANSMITTED)
    led.status(3, 8, TRANSMITTED)
    led.status(3, 9, DELIVERED)
    led.delivered(c, True)
    assert led.lost() == 2  # both in custody, neither delivered nor reported
    led.relay_status(3, 7, EXPIRED)
    led.relay_status(3, 8, FAILED)
    assert led.lost() == 0
    assert led.counts["expired_at_relay"] == 1 and led.counts["failed_at_relay"] == 1
    assert led.final[a] == EXPIRED and led.final[b] == FAILED
    # a report for a packet no relay took, or a second one, is counted apart
    led.relay_status(3, 7, EXPIRED)
    led.relay_status(4, 1, EXPIRED)
    assert led.counts["relay_unknown"] == 2 and led.counts["expired_at_relay"] == 1


def test_a_packet_delivered_after_custody_is_not_lost():
    led = Ledger()
    s = _accept(led, 1, 2)
    led.status(1, 2, TRANSMITTED)
    led.delivered(s, True)
    assert led.lost() == 0 and led.counts["delivered"] == 1
