# Lines the EvoLogics modem sends by itself, for acomm.drivers.evologics:
# receptions (RECVIM in both firmware layouts, RECV, RECVIMS, RECVPBM) become
# EV_RX events, USBL fixes are kept on the driver, and the keywords of the
# notifications the driver only counts.

from ..compat import ticks_add
from ..events import EV_RX
from . import evologics_wire as w

# notifications: keywords that are never a reply
NOTES = (
    b"RECVSTART",
    b"RECVEND",
    b"RECVFAILED",
    b"RECVSRV",
    b"BITRATE",
    b"SRCLEVEL",
    b"PHYON",
    b"PHYOFF",
    b"STATUS",
    b"RADDR",
    b"DROPCNT",
    b"ECLK",
    b"RTO",
    b"USBLPHYD",
    b"USBLPHYP",
    b"EXPIREDIMS",
    b"CANCELEDIMS",
    b"CANCELEDPBM",
    b"SENDSTART",
)
RECV = (b"RECVIM", b"RECV", b"RECVIMS", b"RECVPBM")


def recv(d, now, r, k):
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
    elif k == b"RECVIMS":
        rssi, integ, vel = r.int_field(li + 5), r.int_field(li + 6), r.float_field(li + 7)
    else:
        rssi, integ, vel = r.int_field(li + 4), r.int_field(li + 5), r.float_field(li + 6)
    d.last_rx = {"src": src, "rssi": rssi, "integrity": integ, "velocity": vel}
    d._events.append((EV_RX, src, dst, data))


_LONG = ("ctime", "mtime", "addr", "x", "y", "z", "east", "north", "up", "roll", "pitch", "yaw", "ptime", "rssi",
         "integrity", "accuracy")
_ANGLES = ("ctime", "mtime", "addr", "lbearing", "lelevation", "bearing", "elevation", "roll", "pitch", "yaw", "rssi",
           "integrity", "accuracy")


def usbl(d, r):
    # USBLLONG / USBLANGLES (units as the modem gives them, unconfirmed)
    long = r.is_word(b"USBLLONG")
    names = _LONG if long else _ANGLES
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


def text(r):
    t = r.text()
    try:
        return t.decode()
    except Exception:  # noqa: BLE001 - binary junk in a reply
        return repr(t)
