# Which line from a Benthos ATM-9xx answers which command. A pure function of
# the command outstanding and the line, so the driver (acomm.drivers.benthos)
# stays about state and time, and the matching can be read in one place.
#
#   +++            the prompt (online before: handled by the driver) or
#                  "Command '+++' not found" (command mode already)
#   AT             OK / ERROR
#   @Name=Value    the echo "Name | Value" (the name is checked here, the
#   @Name          value by the caller); "Invalid ...", "Command '...' not
#                  found" or ERROR refuse it
#   ATO            "CONNECT ..." / ERROR / NO CARRIER
#   the payload    "Forwarding Delay Up" (the prompt before it: the driver)
#   ATR<addr>      the Range line for that address / "Response Not
#                  Received" / ERROR; a "TX time ..." line may come first

from ..compat import const
from . import benthos_wire as w

C_ESCAPE = const(1)
C_AT = const(2)
C_SET = const(3)
C_QUERY = const(4)
C_ATO = const(5)
C_PAYLOAD = const(6)
C_RANGE = const(7)

INFO = (None, None)  # a line that belongs to the command without ending it


def answer(kind, name, addr, s):
    # -> (ok, detail) when s ends the command, INFO, or None when s does not
    # answer it. name: the setting of C_SET / C_QUERY; addr: the address
    # of C_RANGE.
    if kind == C_ESCAPE:
        if s == w.NOT_FOUND:
            return True, ""
    elif kind == C_AT:
        if s == "OK" or s == "ERROR":
            return s == "OK", s
    elif kind == C_SET or kind == C_QUERY:
        e = w.parse_echo(s)
        if e is not None and e[0].lower() == name.lower():
            return True, e[1]
        if s == "ERROR" or s.startswith("Invalid") or (s.startswith("Command '") and s != w.NOT_FOUND):
            return False, s
    elif kind == C_ATO:
        if s.startswith("CONNECT"):
            return True, s
        if s == "ERROR" or s == "NO CARRIER":
            return False, s
    elif kind == C_PAYLOAD:
        if s.startswith(w.FWD_UP):
            return True, s
    elif kind == C_RANGE:
        if s[:7].lower() == "tx time":
            return INFO
        r = w.parse_range(s)
        if r is not None and r[1] == addr:
            return True, r
        if s == w.NO_RESPONSE or s == "ERROR":
            return False, s
    return None


def stray(s):
    # an answer of the modem's that comes when nothing is asked (late, or
    # after a command the driver gave up on): known, so not counted as junk
    return s == "OK" or s == w.NOT_FOUND or s.startswith("CONNECT") or s.startswith(w.FWD_UP)
