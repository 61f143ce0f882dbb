# The capture file: every byte that crossed one serial line, each way, with
# its time, so that a session with a real modem (or an emulated one, `acomm
# emulate ... --log FILE`) can be attached to a bug report and fed back
# through a driver (`acomm replay`). JSON lines, one object per line:
#
#   {"capture": "acomm", "version": 1, "modem": "iridium"}     the header
#   {"t": 1520, "to": "device", "hex": "41540d"}             host -> modem
#   {"t": 1523, "to": "host", "hex": "41540d0d0a4f4b0d0a"}   modem -> host
#
#   {"t": 1600, "send": {"addr": 2, "ack": true, "hex": "6869"}}
#                       a request the host's application made (optional:
#                       captures made by acomm's own sessions carry them, so
#                       that a replay can make it again; a capture of other
#                       software or of `acomm emulate --log` has none)
#
# t: integer milliseconds since the capture began, on the host's clock
# (real time for a pty session, virtual time for a simulated one); never
# decreasing. Blank lines are allowed. A file that breaks any of this is
# refused with the number of the first bad line (CaptureError).

import json

VERSION = 1
TO_DEVICE = "device"
TO_HOST = "host"
SEND = "send"


class CaptureError(Exception):
    def __init__(self, line, reason):
        Exception.__init__(self, "line %d: %s" % (line, reason))
        self.line = line
        self.reason = reason


class CaptureWriter:
    # Writes a capture as it happens; record() flushes nothing, close() does.
    def __init__(self, fileobj, modem):
        self.f = fileobj
        self.f.write(json.dumps({"capture": "acomm", "version": VERSION, "modem": modem}) + "\n")
        self._last = 0

    def record(self, t_ms, to, data):
        """One chunk of bytes that went `to` (TO_DEVICE or TO_HOST) at t_ms."""
        if not data:
            return
        t = max(int(t_ms), self._last)  # a clock that steps back is held
        self._last = t
        self.f.write('{"t": %d, "to": "%s", "hex": "%s"}\n' % (t, to, bytes(data).hex()))

    def send(self, t_ms, addr, data, ack):
        """The application asked the driver to send data to addr."""
        t = max(int(t_ms), self._last)
        self._last = t
        self.f.write('{"t": %d, "send": {"addr": %d, "ack": %s, "hex": "%s"}}\n'
                     % (t, addr, "true" if ack else "false", bytes(data).hex()))

    def close(self):
        self.f.close()


def read_capture(lines):
    """(header dict, [(t_ms, to, bytes)]) from the lines of a capture file,
    to being TO_DEVICE, TO_HOST or SEND (then the bytes are a tuple (addr,
    data, ack)); CaptureError(line number, reason) at the first line that is
    not right."""
    header = None
    records = []
    last = 0
    for n, text in enumerate(lines, 1):
        if not text.strip():
            continue
        try:
            obj = json.loads(text)
        except ValueError:
            raise CaptureError(n, "not a JSON object")
        if not isinstance(obj, dict):
            raise CaptureError(n, "not a JSON object")
        if header is None:
            if obj.get("capture") != "acomm":
                raise CaptureError(n, 'the first line must be the header {"capture": "acomm", ...}')
            if obj.get("version") != VERSION:
                raise CaptureError(n, "capture version %r; this acomm reads version %d" % (obj.get("version"), VERSION))
            header = obj
            continue
        t = obj.get("t")
        if not isinstance(t, int) or isinstance(t, bool) or t < 0:
            raise CaptureError(n, '"t" must be a whole number of milliseconds >= 0')
        if t < last:
            raise CaptureError(n, "time goes back (%d ms after %d ms)" % (t, last))
        if SEND in obj:
            records.append((t, SEND, _send(n, obj[SEND])))
            last = t
            continue
        to = obj.get("to")
        if to not in (TO_DEVICE, TO_HOST):
            raise CaptureError(n, '"to" must be "device" or "host"')
        hx = obj.get("hex")
        try:
            data = bytes.fromhex(hx) if isinstance(hx, str) else None
        except ValueError:
            data = None
        if not data:
            raise CaptureError(n, '"hex" must be bytes in hex, at least one')
        last = t
        records.append((t, to, data))
    if header is None:
        raise CaptureError(max(1, len(records)), "empty: no header line")
    return header, records


def _send(n, req):
    if not isinstance(req, dict):
        raise CaptureError(n, '"send" must be an object {"addr", "ack", "hex"}')
    addr = req.get("addr")
    ack = req.get("ack", False)
    hx = req.get("hex")
    if not isinstance(addr, int) or isinstance(addr, bool) or not isinstance(ack, bool):
        raise CaptureError(n, '"send" needs a whole "addr" and a true/false "ack"')
    try:
        data = bytes.fromhex(hx) if isinstance(hx, str) else None
    except ValueError:
        data = None
    if not data:
        raise CaptureError(n, '"send": "hex" must be bytes in hex, at least one')
    return (addr, data, ack)
