# The fault modes the four modem emulators share, for driver tests: noise
# on the serial line, a damaged or truncated output line, a command that is
# never answered (or carried out without its answer), and a restart at any
# moment, deaf for boot_ms, then the power-up text.
#
# What a fault is keyed by differs per modem (a SeaTrac CID, an EvoLogics
# line prefix, a Micro-Modem sentence type, a Benthos kind of output; each
# emulator's header says which); an emulator that normalises keys overrides
# _fault_key, and one whose keys match other than by equality overrides
# _fault_matches. Arming and bookkeeping are here:
#
#   corrupt_next(key, count)     the next output line(s) come out damaged
#                                (a wrong checksum where the protocol has one)
#   truncate_next(key, count, terminate)   they stop half way, with their
#                                line end or (terminate=False) without
#   swallow_next(key, count, execute)      the next command(s) are never
#                                answered; execute=True still carries them out
#
# A fault is [kind, key or None (any), count, option]: kind "corrupt",
# "truncate" or "swallow"; option is `terminate` or `execute`.
#
# Needs from the emulator: _out (SansIO), _booting_until (None while up),
# banner (lines without their end), boot_ms and _booted(now); for
# _leave_medium / _join_medium, medium and an xcvr that has addr and reset()
# (the Benthos emulator is its own node on the medium and does without).

from acomm.compat import ticks_add, ticks_diff

CRLF = b"\r\n"


class FaultModes:
    def inject_noise(self, data):
        self._out.extend(data)

    def corrupt_next(self, key=None, count=1):
        self._add_fault("corrupt", key, count, None)

    def truncate_next(self, key=None, count=1, terminate=True):
        self._add_fault("truncate", key, count, terminate)

    def swallow_next(self, key=None, count=1, execute=False):
        self._add_fault("swallow", key, count, execute)

    def _fault_key(self, key):
        return key

    def _add_fault(self, kind, key, count, option):
        self._faults.append([kind, self._fault_key(key), count, option])

    def _fault_matches(self, f, key):
        return f[1] is None or f[1] == key

    def _fault(self, kinds, key):
        # The first pending fault of one of these kinds that applies to key,
        # counted off (and forgotten when used up); None when there is none.
        for f in self._faults:
            if f[0] in kinds and self._fault_matches(f, key):
                f[2] -= 1
                if f[2] <= 0:
                    self._faults.remove(f)
                return f
        return None

    # -- restarts ----------------------------------------------------------------
    def booting(self):
        return self._booting_until is not None

    def _start_boot(self, now):
        self._booting_until = ticks_add(now, self.boot_ms)

    def _still_booting(self, now):
        # For poll(): True while the restart lasts; at its end the emulator
        # is up again and its _booted(now) prints the power-up text.
        if self._booting_until is None:
            return False
        if ticks_diff(now, self._booting_until) < 0:
            return True
        self._booting_until = None
        self._booted(now)
        return False

    def _leave_medium(self, now):
        # a restart cuts our packet short and nobody hears us until it ends
        x = self.xcvr
        x.reset()
        self.medium.cancel(x.addr, now)
        self.medium.detach(x.addr)

    def _join_medium(self, addr):
        # back up, at the address the (possibly changed) settings give
        self.xcvr.addr = addr
        self.medium.attach(addr, self.xcvr)

    def _print_banner(self):
        for ln in self.banner:
            self._out.extend(ln)
            self._out.extend(CRLF)


def cut(data, terminate):
    # A truncated line: its first half, with CR LF or (terminate=False)
    # running into whatever comes next.
    return data[: len(data) // 2] + (CRLF if terminate else b"")


def hit(data, i):
    # A line with one character damaged, for protocols without a checksum:
    # a '#' at i, where the driver will find a word it does not know.
    b = bytearray(data)
    b[i] = 0x23
    return bytes(b)


def digit_off(buf, i):
    # one checksum digit wrong, whatever it was
    buf[i] = 0x30 if buf[i] != 0x30 else 0x31
