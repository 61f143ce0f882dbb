# The EvoLogics driver's notifications: the lines an S2C sends unasked
# (receptions, the outcome of an IM or a burst, the end of a transmission,
# USBL fixes, and the ones only counted), told from replies by their
# keyword, so they may arrive at any time. Functions of the driver
# (acomm.drivers.evologics.EvologicsDriver, `d`), which calls
# notification() first for every line; docs/drivers-evologics.md maps
# each to acomm's events.

from ..compat import ticks_add
from ..events import EV_DELIVERED, EV_RX, EV_TX_FAILED
from . import evologics_wire as w
from .evologics_sequences import K_BURST, K_IM, K_IM_ACK, K_PING


def notification(d, now, r):
    """Acts on line r (an evologics_wire reader line) when it is a notification; -> False for a reply or a value."""
    for k in w.RECV:
        if r.is_word(k):
            _recv(d, now, r, k)
            return True
    if r.is_word(b"DELIVEREDIM") or r.is_word(b"FAILEDIM") or r.is_word(b"CANCELEDIM"):
        _im_outcome(d, r)
    elif r.is_word(b"DELIVERED") or r.is_word(b"FAILED"):
        _burst_outcome(d, r)
    elif r.is_word(b"SENDEND"):
        _send_end(d, r)
    elif r.is_word(b"USBLLONG") or r.is_word(b"USBLANGLES"):
        _usbl(d, r)
    else:
        for k in w.NOTES:
            if r.is_word(k):
                d.stats["notes"] += 1
                return True
        if not (r.starts(b"ERROR EFAULT") or r.starts(b"ERROR OVERLOAD")):
            return False
        d.stats["async_errors"] += 1  # not replies (evins treats them so)
    return True


def _recv(d, now, r, k):
    # RECVIM (in both firmware layouts), RECV, RECVIMS, RECVPBM: EV_RX
    data = r.data()
    li = 1
    f1 = r.field(1)
    if f1 and f1[0] == 112:  # p<pid>
        li = 2
    src = r.int_field(li + 1)
    dst = r.int_field(li + 2)
    if data is None or src is None or dst is None or not 0 <= src <= 255 or not 0 <= dst <= 255:
        d.stats["malformed"] += 1
        return
    if k == b"RECVIM":
        flag = r.field(li + 3)
        base = li + 4
        if d._reader.specs is w.RX_SPECS_16:
            rssi, integ, vel = r.int_field(base + 1), r.int_field(base + 2), r.float_field(base + 4)
        else:
            rssi, integ, vel = r.int_field(base + 1), r.int_field(base + 2), r.float_field(base + 3)
        own = d.config.own_addr
        if flag == b"ack" and own is not None and dst == own:
            # our modem acknowledges by itself: it is busy meanwhile
            d._hold_until = ticks_add(now, d.turnaround_ms + d.airtime_ms(0))
    elif k == b"RECV":
        rssi, integ, vel = r.int_field(li + 4), r.int_field(li + 5), r.float_field(li + 7)
        if dst == d.config.own_addr:
            # burst data is always acknowledged, by our modem itself
            d._hold_until = ticks_add(now, d.turnaround_ms + d.airtime_ms(0))
    elif k == b"RECVIMS":
        rssi, integ, vel = r.int_field(li + 5), r.int_field(li + 6), r.float_field(li + 7)
    else:
        rssi, integ, vel = r.int_field(li + 4), r.int_field(li + 5), r.float_field(li + 6)
    d.last_rx = {"src": src, "rssi": rssi, "integrity": integ, "velocity": vel}
    d._events.append((EV_RX, src, dst, data))

def _usbl(d, r):
    # USBLLONG / USBLANGLES (units as the modem gives them, unconfirmed)
    long = r.is_word(b"USBLLONG")
    names = w.USBL_LONG if long else w.USBL_ANGLES
    if r.nc != len(names):
        d.stats["malformed"] += 1
        return
    fix = {}
    for i in range(len(names)):
        v = r.float_field(i + 1)
        if v is None:
            d.stats["malformed"] += 1
            return
        fix[names[i]] = v
    fix["addr"] = int(fix["addr"])
    if long:
        d.last_fix = fix
    else:
        d.last_angles = fix

def _im_outcome(d, r):
    dst = r.int_field(1)
    slot = d.slot
    if dst is None or not slot.awaiting((K_IM_ACK, K_PING), dst):
        d.stats["stale"] += 1
        return
    if r.is_word(b"DELIVEREDIM"):
        if slot.kind == K_IM_ACK and d.ptime_after_ack:
            d._ptime = True
        slot.delivered()
    else:
        slot.undelivered(r.shown().split(",")[0])

def _burst_outcome(d, r):
    dst = r.int_field(2)
    for b in d.awaiting:
        if b[1] == dst:
            # the oldest burst to dst: the modem reports them in order
            d.awaiting.remove(b)
            ok = r.is_word(b"DELIVERED")
            d._events.append((EV_DELIVERED, b[0]) if ok else (EV_TX_FAILED, b[0], "FAILED"))
            return
    slot = d.slot
    if dst is None or not slot.awaiting((K_BURST,), dst):
        d.stats["stale"] += 1
        return
    if r.is_word(b"DELIVERED"):
        slot.delivered()
    else:
        slot.undelivered("FAILED")

def _send_end(d, r):
    addr = r.int_field(1)
    if addr is not None and d.slot.awaiting((K_IM, K_IM_ACK, K_BURST, K_PING), addr):
        d.slot.send_end()
    else:
        d.stats["stale"] += 1

