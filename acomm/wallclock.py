# The node's one wall clock (issue 37 point 2): seconds for the transport's
# lifespans, the key's counter epochs and the store, set from the sky when a
# driver can tell the time (Iridium AT-MSSTM, GSM AT+CCLK?, a GPS's NMEA) and
# the port's own clock until then. docs/core-loop.md "Wall clock" has the
# rules; in short:
#
# - It is an offset plus the port's ticks: wall() = anchor + elapsed ticks,
#   in the port's wall units (seconds; a board counts from 2020-01-01,
#   CPython from 1970: epoch_s is the port's value of 2020-01-01 00:00 UTC).
# - Before any source ("none") it follows the port's wall(): re-read at each
#   poll (the node's step), a port clock that moved forward by 2 s or more is a step; one
#   that went back is not followed. With host=True (a PC whose clock is set
#   by NTP) it does the same for ever, as source "host", and fixes from the
#   drivers never move it.
# - A fix (seconds since 2020-01-01 UTC, ms, uncertainty in ms) earlier than
#   2024-01-01 is no source (a modem RTC never set, a GPS week rollover).
#   The first fix is taken at once. Later, a fix within the clock's
#   uncertainty plus the fix's plus 1 s is taken; a bigger step needs
#   confirmation: a second fix that agrees with the first (the same
#   tolerances), from another source or at least 5 s later. A lone bad fix
#   is kept as the candidate and moves nothing.
# - It never goes backwards: a correction back holds wall() at the value it
#   had until the corrected time passes it. A step forward calls every
#   on_step(fn) listener with fn(delta_s) (the transport moves the expiry of
#   the packets it timed before the step).
# - With a path, the last good time is written there at most once per hour
#   of uptime and a minute after each accepted step of 2 s or more (at most
#   once per hour plus once per step), and the clock
#   starts no earlier than it after a reboot (a board without a battery RTC
#   would start again at its power-up date).

from .compat import const, ticks_add, ticks_diff, ticks_ms

# 2024-01-01 00:00 UTC in seconds from 2020-01-01: an earlier fix is a
# modem's power-up date (2000, 2002, 2004, 1980), not the time
MIN_S = const(126230400)
_MAX_S = const(1073741823)  # 2054: the end of a board's small integers
_TOL_MS = const(1000)  # beyond both uncertainties: the poll loop, the line's transfer
_CONFIRM_MS = const(5000)  # a confirming fix of the same source comes this much later
_SAVE_MS = const(3600000)  # at most one write of the time file per hour
_STEP_SAVE_S = const(2)
_STEP_SAVE_MS = const(60000)  # a step is written this long after it
_REBASE_MS = const(1 << 27)  # re-anchor before ticks_diff runs out (2**29 on a board)
_DRIFT_PPM = const(100)  # a crystal's drift: the uncertainty grows 0.1 ms a second


class WallClock:
    """Wall seconds = anchor + ticks, set by the port's clock until a source speaks, never backwards."""

    # defaults kept on the class: a board's instance holds only what it
    # changed (every name, here or there, is a slot of a board's heap)
    path = None
    epoch_s = 0
    _listeners = ()
    _cand = None  # a big step waiting for its confirmation: (s, ms, t, unc, source)
    saves = 0  # writes of the time file

    def __init__(self, wall=None, ticks=None, path=None, epoch_s=0, host=False):
        """wall() -> the port's seconds; ticks() -> ms; path: the last good time's file (or None);
        epoch_s: the port's wall at 2020-01-01 UTC; host: the port's clock is set (NTP) and stays the source."""
        if wall is None:
            import time

            wall = time.time
        self._port = wall
        self.ticks = ticks or ticks_ms
        if path is not None:
            self.path = path
        if epoch_s:
            self.epoch_s = epoch_s
        now = self.ticks()
        s = int(wall())
        if path is not None:
            try:
                with open(path) as f:
                    saved = int(f.read().strip())
                if saved > s:
                    s = saved
            except (OSError, ValueError):
                pass  # none yet, or a write cut short: start as the port's clock says
        # every field a fix sets is set here, in the build: a board's
        # instance table that grew at the first fix was reallocated in the
        # middle of a step (a hole in the heap when it is busiest)
        self.source = "host" if host else "none"  # or "iridium", "gsm", "gps"
        self._s = s
        self._ms = 0
        self._t = now
        self._unc = 0  # the last fix's uncertainty, at the anchor's ticks
        self._last = s
        self._saved_t = now

    # -- reading --------------------------------------------------------------------
    def wall(self, now=None):
        """The wall clock's seconds now (an int, never less than a value returned before)."""
        # the anchor's time at now (ticks) in whole seconds, held at the last
        # value returned after a correction back; re-anchored before the
        # ticks' difference could wrap. One method with what was _read(now):
        # a method is a function object on a board's heap
        if now is None:
            now = self.ticks()
        d = ticks_diff(now, self._t) + self._ms
        s = self._s + d // 1000
        if d >= _REBASE_MS:
            self._unc += d // (1000000 // _DRIFT_PPM)  # the drift so far: uncertainty from the new anchor
            self._s = s
            self._ms = d % 1000
            self._t = now
        if s < self._last:
            return self._last
        self._last = s
        return s

    def uncertainty_ms(self, now=None):
        """How far off the clock may be, in ms (the last fix's plus 100 ppm since); None without a source."""
        if self.source == "none" or self.source == "host":
            return None
        if now is None:
            now = self.ticks()
        return self._unc + ticks_diff(now, self._t) // (1000000 // _DRIFT_PPM)

    def on_step(self, fn):
        """Calls fn(delta_s) whenever the clock steps forward (a fix, the port's clock set)."""
        if not self._listeners:
            self._listeners = []
        self._listeners.append(fn)

    # -- setting --------------------------------------------------------------------
    def fix(self, now, source, secs, ms, unc_ms):
        """A time from a source ("iridium", "gsm", "gps"): secs from 2020-01-01 UTC, ms, uncertainty.
        -> True when the clock took it (see the rules above)."""
        if self.source == "host" or not MIN_S <= secs <= _MAX_S:
            return False  # the host's clock is better; a date before 2024 is no time
        s = secs + self.epoch_s
        c = self._cand
        if self.source != "none" and not _near(s, ms, now, self._s, self._ms, self._t,
                                               self.uncertainty_ms(now) + unc_ms + _TOL_MS):
            # a step beyond both uncertainties: only when confirmed
            if c is None or not _near(s, ms, now, c[0], c[1], c[2], c[3] + unc_ms + _TOL_MS):
                self._cand = (s, ms, now, unc_ms, source)
                return False
            if c[4] == source and ticks_diff(now, c[2]) < _CONFIRM_MS:
                return False  # the same source, too soon: the same glitch told twice
        before = self.wall(now)
        self._s = s
        self._ms = ms
        self._t = now
        self._unc = unc_ms
        if c is not None:
            self._cand = None  # (written only when set: the class's None until a candidate)
        self.source = source
        self._moved(now, before, s)
        return True

    def _moved(self, now, before, s):
        # the anchor moved: forward is a step for the listeners, back is held
        if s < before:
            return  # held (wall)
        self._last = s
        if s > before:
            for fn in self._listeners:
                fn(s - before)
            if s - before >= _STEP_SAVE_S and self.path is not None:
                # written a minute later (poll), not in the middle of the
                # step that brought the fix: a board's heap is busiest then
                self._saved_t = ticks_add(now, _STEP_SAVE_MS - _SAVE_MS)

    def poll(self, now):
        """The node's step: the port's clock read again (no source yet), the hourly save."""
        if self.source == "none" or self.source == "host":
            w = int(self._port())
            before = self.wall(now)
            if w >= before + _STEP_SAVE_S:
                # the port's clock was set (or jumped) forward: follow it
                self._s = w
                self._ms = 0
                self._t = now
                self._moved(now, before, w)
        if self.path is not None and ticks_diff(now, self._saved_t) >= _SAVE_MS:
            # the last good time, across a reboot (read back in __init__);
            # here, not a method of its own (a board's heap)
            self._saved_t = now
            import os

            tmp = self.path + ".new"
            try:
                with open(tmp, "w") as f:
                    f.write("%d\n" % self.wall(now))
                os.rename(tmp, self.path)
                self.saves += 1
            except OSError:
                pass  # a full or failing flash: the clock goes on, saved again in an hour


def _near(s, ms, now, s0, ms0, t0, tol_ms):
    # whether the time (s, ms) at `now` is within tol_ms of the anchor
    # (s0, ms0) at t0 carried forward to now; seconds first, so that a
    # board compares small integers even for a step of years
    d = ticks_diff(now, t0) + ms0
    ds = s - s0 - d // 1000
    if ds > 100000 or ds < -100000:
        return False
    return abs(ds * 1000 + ms - d % 1000) <= tol_ms
