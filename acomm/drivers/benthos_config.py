# What the Benthos driver sends before it lets the link transmit, and again
# after the modem restarted or fell silent. The driver first brings the
# modem to command mode (`+++` after the guard time, see benthos.py), then:
#
#   AT                 -> OK: someone is there and in command mode
#   @P1EchoChar=Dis    the recommended goby setup (ref/modem-protocols.md
#   @P1Prompt=7        4.2), each answered by its echo "Name | Value",
#   @Verbose=3         which is checked
#   @DataRetry=Dis
#   @FwdDelay=0.05
#   @LocalAddr=<id>    only when the constructor was given an address
#   @PrintHex=Ena
#   @RcvAll=Ena        (option)
#   @ShowBadData=Ena
#   @OpMode=0
#   @TxRate=<code>
#   @AcRspTmOut=<s>    (option) the reply timeout the driver's watchdog uses
#   ...extra settings given to the constructor
#   @LocalAddr         a query, only when no address was given
#
# goby also sets @WakeTones=Ena (for low power) and the modem clock; the
# driver never sends the modem to low power and has no wall clock, so
# neither is in the default list (add WakeTones with `extra_settings`).

from ..compat import ticks_add, ticks_diff
from ..events import EV_DRIVER_DOWN
from . import benthos_wire as w

S_AT = 0
S_SET = 1
S_QUERY = 2


def setup_steps(address, tx_rate, fwd_delay_ms, rcv_all, ac_rsp_tmo_ms, extra, prompt_setting="P1Prompt"):
    # prompt_setting: goby3 at 0bba729 writes @Prompt=7, the reference
    # (goby3 at 2603ff12) @P1Prompt=7
    steps = [(S_AT, "", ""), (S_SET, "P1EchoChar", "Dis"), (S_SET, prompt_setting, "7"), (S_SET, "Verbose", "3")]
    steps.append((S_SET, "DataRetry", "Dis"))
    steps.append((S_SET, "FwdDelay", w.secs_text(fwd_delay_ms)))
    if address is not None:
        steps.append((S_SET, "LocalAddr", str(address)))
    steps.append((S_SET, "PrintHex", "Ena"))
    if rcv_all is not None:
        steps.append((S_SET, "RcvAll", "Ena" if rcv_all else "Dis"))
    steps.append((S_SET, "ShowBadData", "Ena"))
    steps.append((S_SET, "OpMode", "0"))
    steps.append((S_SET, "TxRate", str(tx_rate)))
    if ac_rsp_tmo_ms is not None:
        steps.append((S_SET, "AcRspTmOut", w.secs_text(ac_rsp_tmo_ms)))
    for name, value in extra:
        steps.append((S_SET, name, str(value)))
    if address is None:
        steps.append((S_QUERY, "LocalAddr", ""))
    return steps


class BenthosConfig:
    def __init__(self, driver, steps, retry_ms):
        self.d = driver
        self.steps = steps
        self.retry_ms = retry_ms
        self.i = 0
        self.fails = 0
        self.down_reported = False
        self.problem = None  # the last reason the setup failed
        self.mismatch = {}  # settings the modem echoed with another value
        self._wait = None

    def start(self, now):
        self.i = 0
        self._wait = None

    def pump(self, now):
        # called by the driver when the modem is in command mode and no
        # command is outstanding
        if self._wait is not None:
            if ticks_diff(now, self._wait) < 0:
                return
            self._wait = None
        kind, name, value = self.steps[self.i]
        d = self.d
        if kind == S_AT:
            d.command_at(now, "AT")
        elif kind == S_SET:
            d.command_set(now, name, value)
        else:
            d.command_query(now, name)

    def reply(self, now, ok, detail):
        # the outcome of the current step's command
        kind, name, value = self.steps[self.i]
        if not ok:
            what = "AT" if kind == S_AT else ("@" + name + ("=" + value if kind == S_SET else ""))
            self.failed(now, "%s: %s" % (what, detail))
            return
        if kind == S_QUERY and name == "LocalAddr":
            a = w.number(detail)
            if a is None or a > w.MAX_ADDR:
                self.failed(now, "LocalAddr is %r" % (detail,))
                return
            self.d.address = a
        elif kind == S_SET and not w.same_value(value, detail):
            if w.milli(value) is not None:
                # a number the modem did not take (an address, a rate)
                self.failed(now, "%s is %s, not %s" % (name, detail, value))
                return
            self.mismatch[name] = detail
        self.i += 1
        if self.i >= len(self.steps):
            self.fails = 0
            self.problem = None
            self.down_reported = False
            self.d.configured(now)

    def failed(self, now, reason):
        # Start over after a pause (from the escape: the modem may have
        # gone back online); say the modem is down once per outage.
        self.problem = reason
        self.fails += 1
        d = self.d
        if self.fails >= d.down_after and not self.down_reported:
            self.down_reported = True
            d._events.append((EV_DRIVER_DOWN, reason))
        self.i = 0
        self._wait = ticks_add(now, self.retry_ms)
        d.resync()
