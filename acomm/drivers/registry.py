# The modems acomm drives: one table, used by the board port (acomm_mp), the
# simulator (acomm_sim), the command line (`acomm node --modem`, `acomm run`)
# and the IMC bridge. A modem's driver is the class the table names, in the
# module of the modem's name (acomm.drivers.<name>), imported on first use:
# a board loads (and `acomm flash` copies) only the drivers of its modems.
#
# An entry: (name, driver class, default baud, medium, addressed)
#   medium     the kind a link on this modem gets (Link.medium): what a
#              transport's medium names and the router prefers
#   addressed  the driver takes the modem's address (the node id) as its
#              first argument; the rest are keyword options (docs/drivers.md)
# A tuple of constant tuples: frozen, it stays in flash.

from ..errors import AcommError

MODEMS = (
    ("seatrac", "SeatracDriver", 115200, "acoustic", True),
    ("evologics", "EvologicsDriver", 19200, "acoustic", True),
    ("micromodem", "MicroModemDriver", 19200, "acoustic", True),
    ("benthos", "BenthosDriver", 9600, "acoustic", True),
    ("iridium", "IridiumDriver", 19200, "satellite", True),
    ("sms", "SmsDriver", 115200, "gsm", True),
    # no address, no start-up: SLIP frames on a serial cable or a radio
    ("transparent", "TransparentDriver", 9600, "radio", False),
)


def modem(name):
    """The table's entry for the modem called name; AcommError names the known ones."""
    for m in MODEMS:
        if m[0] == name:
            return m
    raise AcommError("unknown modem %r (one of %s)" % (name, ", ".join(names())))


def names():
    """The modems' names, in the table's order."""
    return [m[0] for m in MODEMS]


def driver_class(name):
    """The driver class of the modem called name (its module imported now); AcommError if unknown."""
    cls = modem(name)[1]
    return getattr(__import__("acomm.drivers." + name, None, None, (cls,)), cls)
