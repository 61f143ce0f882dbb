# The emulated GSM network behind emulated GSM modems (acomm_sim.gsm): a
# service centre that takes each submitted SMS and delivers it after
# delay_ms to the modem with the destination's number, on injected time.
# A modem whose storage is full (or that is restarting) does not take the
# message: the centre tries again every retry_ms, as a real SMSC keeps a
# message for a phone that is off, until max_tries. Messages to numbers
# with no modem (a shore phone) are kept in `log` (bounded), with every
# other submitted message; queue_sms() puts a message on its way to a modem
# from outside (a test, `acomm emulate gsm --mt`).
#
# The network's operator (AT+COPS: long, short and numeric names; MCC 001
# MNC 01 is the test network) and the SMSC number its SIMs hold (AT+CSCA).
#
# network_of(medium) finds the network of a medium (a GsmNetwork itself,
# or one made once and kept on any other object, such as the acoustic
# medium of a World or of `acomm emulate`).

from acomm.compat import ticks_add, ticks_diff

from .atmodem import shared_network

_LOG_MAX = 100


def digits(number):
    return number.lstrip("+")


class GsmNetwork:
    def __init__(self, delay_ms=3000, retry_ms=10000, max_tries=30, operator=(b"ACOMM SIM", b"ACOMM", b"00101"),
                 smsc="+10000000001"):
        self.operator = operator
        self.smsc = smsc
        self.delay_ms = delay_ms
        self.retry_ms = retry_ms
        self.max_tries = max_tries
        self.modems = {}  # digits -> emulator
        self.log = []  # (ticks, from, to, dcs, bytes), newest last
        self.undeliverable = 0
        self.expired = 0
        self._flight = []  # [when, to, from, dcs, data, tries]

    def attach(self, emu):
        self.modems[digits(emu.number)] = emu

    def submit(self, now, src, dst, dcs, data):
        self.log.append((now, src, dst, dcs, data))
        if len(self.log) > _LOG_MAX:
            self.log.pop(0)
        self._flight.append([ticks_add(now, self.delay_ms), dst, src, dcs, data, 0])

    def queue_sms(self, now, dst, data, src="+10000000000", dcs=0x04):
        self._flight.append([now, dst, src, dcs, bytes(data), 0])
        self.poll(now)

    def busy(self):
        return bool(self._flight)

    def poll(self, now):
        if not self._flight:
            return
        keep = []
        for f in self._flight:
            if ticks_diff(now, f[0]) < 0:
                keep.append(f)
                continue
            m = self.modems.get(digits(f[1]))
            if m is None:
                self.undeliverable += 1
            elif not m.store(now, f[2], f[3], f[4]):
                f[5] += 1
                if f[5] >= self.max_tries:
                    self.expired += 1
                else:
                    f[0] = ticks_add(now, self.retry_ms)
                    keep.append(f)
        self._flight = keep


def network_of(medium):
    return shared_network(medium, GsmNetwork, "gsm_network")
