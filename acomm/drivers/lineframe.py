# Cutting a serial byte stream into lines that start with a sync character
# and end in CR, LF or both: what the SeaTrac reader ('#' / '$' hex lines,
# seatrac_wire) and the Micro-Modem reader ('$' NMEA sentences,
# micromodem_nmea) share. Only the bounds of a line are found here; the
# subclass checks and decodes a whole one in _end_line(n), with the bytes
# between sync and line end in self._line[:n].
#
# Framing trouble is counted in self.junk and reported to sink.on_junk(kind):
# characters outside any line (noise, boot text), a line cut short by the
# next sync, and a line longer than the buffer. Each protocol names these
# kinds its own way (ints in one, strings in the other: they are the keys
# callers read in junk), so the subclass passes its names in.
# One preallocated buffer; nothing is allocated per byte.


class SyncLines:
    def __init__(self, sync, sink, cap, text, truncated, overlong):
        self.sync = sync
        self._sink = sink
        self._line = bytearray(cap)
        self._k_text = text
        self._k_cut = truncated
        self._k_long = overlong
        self.junk = {}
        self.reset()

    def reset(self):
        self._n = 0
        self._in = False
        self._over = False
        self._text = 0  # characters seen outside any line

    def _junk(self, kind):
        self.junk[kind] = self.junk.get(kind, 0) + 1
        self._sink.on_junk(kind)

    def feed(self, data):
        sync = self.sync
        line = self._line
        cap = len(line)
        n = self._n
        for b in data:
            if b == sync:
                if self._in:
                    self._n = n
                    self._junk(self._k_cut)
                elif self._text:
                    self._junk(self._k_text)
                self._in = True
                self._over = False
                self._text = 0
                n = 0
            elif b == 13 or b == 10:
                if self._in:
                    self._in = False
                    self._n = n
                    if self._over:
                        self._over = False
                        self._junk(self._k_long)
                    else:
                        self._end_line(n)
                    n = 0
                elif self._text:
                    self._text = 0
                    self._junk(self._k_text)
            elif self._in:
                if n < cap:
                    line[n] = b
                    n += 1
                else:
                    self._over = True
            else:
                self._text += 1
        self._n = n
