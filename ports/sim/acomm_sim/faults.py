# The fault modes the four modem emulators share, for driver tests: noise
# on the serial line, a damaged or truncated output line, a command that is
# never answered (or carried out without its answer), and a restart at any
# moment, deaf for boot_ms, then the power-up text.
#
# Each emulator keeps its own corrupt_next / truncate_next / swallow_next,
# because what a fault is keyed by differs (a CID, a line prefix, a sentence
# type, a kind of output) and so do the names tests and docs use for it; it
# files them with _add_fault and, where a key matches other than by
# equality, says so in _fault_matches. The bookkeeping is here.
#
# A fault is [kind, key or None (any), count, option]: option is
# `terminate` for "truncate", `execute` for "swallow".
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

    def _add_fault(self, kind, key, count, option):
        self._faults.append([kind, key, count, option])

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
