# The modems a board can name in its configuration, and where their sans-IO
# drivers live. Drivers are imported by name on first use, so a board loads
# (and `acomm flash` copies) only the drivers of the modems it has.
#
# Every driver takes the modem's address as its first argument and the rest
# as keyword options (the config's "options").

MODEMS = {
    "seatrac": ("acomm.drivers.seatrac", "SeatracDriver"),
    "evologics": ("acomm.drivers.evologics", "EvologicsDriver"),
    "micromodem": ("acomm.drivers.micromodem", "MicroModemDriver"),
    "benthos": ("acomm.drivers.benthos", "BenthosDriver"),
    "iridium": ("acomm.drivers.iridium", "IridiumDriver"),
    "sms": ("acomm.drivers.sms", "SmsDriver"),
}


def driver_class(modem):
    mod, cls = MODEMS[modem]
    return getattr(__import__(mod, None, None, [cls]), cls)
