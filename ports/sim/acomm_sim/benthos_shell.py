# The command-mode shell of an emulated Benthos ATM-9xx: CLAM settings
# (`@Name=Value` answered by the echo `Name | Value`, `@Name` queries) and the
# Hayes AT commands the driver and a person at a terminal use. One command
# line in, its answer lines out through the modem's emit(); the modem prints
# the prompt afterwards unless the command went online, started an acoustic
# exchange (ATR) or restarted the modem.
#
# Power-up values that the reference does not give (ref/modem-protocols.md
# section 8) are this emulator's choices: echo on, online at power-up
# (goby's comment "@OpMode=1 is the default"), FwdDelay 0.5 s, AcRspTmOut
# 10 s, PrintHex/RcvAll/ShowBadData off. The texts of ERROR, ATI, ATV and of
# a refused setting are not confirmed either.

from acomm.drivers import benthos_wire as w

_WORDS = ("Ena", "Dis")


def defaults(address, tx_rate):
    # name -> value as the modem prints it
    return {
        "P1Baud": "9600",
        "P1EchoChar": "Ena",
        "P1FlowCtl": "0",
        "P1Prompt": "7",
        "Verbose": "1",
        "DataRetry": "Ena",
        "FwdDelay": "0.5",
        "LocalAddr": str(address),
        "RemoteAddr": "0",
        "TxRate": str(tx_rate),
        "PrintHex": "Dis",
        "RcvAll": "Dis",
        "ShowBadData": "Dis",
        "OpMode": "1",
        "WakeTones": "Dis",
        "AcRspTmOut": "10.0",
    }


# numeric settings: (lowest, highest, step) in thousandths
_RANGES = {
    "P1Baud": (1200000, 115200000, 1000),
    "P1FlowCtl": (0, 3000, 1000),
    "P1Prompt": (0, 7000, 1000),
    "Verbose": (0, 3000, 1000),
    "FwdDelay": (50, 5000, 50),
    "LocalAddr": (0, w.MAX_ADDR * 1000, 1000),
    "RemoteAddr": (0, w.BROADCAST * 1000, 1000),
    "TxRate": (2000, 13000, 1000),
    "OpMode": (0, 2000, 1000),
    "AcRspTmOut": (2000, 99500, 500),
}


def canonical(name, value):
    # The value as the modem keeps it, or None when it is refused.
    if name in _RANGES:
        v = w.milli(value)
        lo, hi, step = _RANGES[name]
        if v is None or not lo <= v <= hi or v % step:
            return None
        if name == "RemoteAddr" and w.MAX_ADDR * 1000 < v < w.BROADCAST * 1000:
            return None
        if step % 1000 == 0:
            return str(v // 1000)
        return w.secs_text(v)
    low = value.lower()
    if low in ("ena", "1", "on"):
        return "Ena"
    if low in ("dis", "0", "off"):
        return "Dis"
    return None


class Shell:
    def __init__(self, modem):
        self.m = modem
        self._names = {}
        for k in modem.settings:
            self._names[k.lower()] = k

    def run(self, now, line):
        # Executes one command line; returns True when the prompt follows.
        m = self.m
        if not line:
            return True
        if line[0] == "@":
            self._setting(line[1:])
            return True
        up = line.upper()
        if up.startswith("AT"):
            return self._at(now, up[2:])
        if line.lower().startswith("cfg store"):
            m.stored = dict(m.settings)
            m.emit("reply", "Configuration stored.")
            return True
        m.emit("reply", "Command '%s' not found" % line)
        return True

    def _setting(self, text):
        m = self.m
        i = text.find("=")
        key = text if i < 0 else text[:i]
        name = self._names.get(key.strip().lower())
        if name is None:
            m.emit("reply", "Invalid parameter %s" % key)
            return
        if i >= 0:
            v = canonical(name, text[i + 1 :].strip())
            if v is None or (name == "LocalAddr" and not m.readdress(int(v))):
                m.emit("reply", "Invalid value for %s" % name)
                return
            m.settings[name] = v
        m.emit("reply", w.echo_line(name, m.settings[name]))

    def _at(self, now, rest):
        m = self.m
        if rest == "":
            m.emit("reply", "OK")
        elif rest == "O":
            m.go_online(now)
            return False
        elif rest[:1] == "D" and w.number(rest[1:]) is not None:
            v = canonical("RemoteAddr", rest[1:])
            if v is None:
                m.emit("reply", "ERROR")
                return True
            m.settings["RemoteAddr"] = v
            m.go_online(now)
            return False
        elif rest[:1] == "R":
            a = w.number(rest[1:])
            if a is None or a > w.MAX_ADDR or a == m.address or not m.xcvr.ping(now, a):
                m.emit("reply", "ERROR")
                return True
            return False  # the prompt comes with the result
        elif rest == "H":
            m.emit("reply", "OK")
        elif rest == "I":
            m.emit("reply", "ATM-900 series acoustic modem (acomm emulator)")
            m.emit("reply", "Firmware emulated 1.0, serial %06d" % m.serial)
        elif rest == "V":
            m.emit("reply", "Voltage %s V  Temperature %s C" % (w.fmt1(m.voltage), w.fmt1(m.temperature)))
        elif rest == "&W":
            m.stored = dict(m.settings)
            m.emit("reply", "OK")
        elif rest == "&F":
            m.settings = defaults(m.settings["LocalAddr"], m.factory_rate)
            m.emit("reply", "OK")
        elif rest == "ES":
            m.emit("reply", "OK")
            m.reboot(now)
            return False
        else:
            m.emit("reply", "ERROR")
        return True
