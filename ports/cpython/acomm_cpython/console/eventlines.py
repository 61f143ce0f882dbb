# What a console prints: every node event and every answer to a command as
# a dict (JSON lines with --json, and in the --log file), and the same dict
# as one readable line on a terminal. One place decides both, so a script
# reading JSON and a person reading text see the same facts.
#
#   as_dict(ev) -> dict or None      a node listener event (acomm.events)
#   as_text(d) -> str or None        the readable line of any dict here
#   Output(stream, json, log)        prints dicts; draws a progress line
#                                    on a terminal

import json
import time

import acomm.events as E
from acomm.events import (AVAIL_NAMES, EV_AVAILABILITY, EV_PACKET, EV_PACKET_STATUS, EV_RANGE_RECEIVED, EV_RECEIVED,
                          EV_REFUSED, EV_RELAY_STATUS, EV_STATUS, STATUS_NAMES, is_final)

from ..eventview import RELAY_ORIGIN, RELAY_PID, RELAY_REASON, RELAY_STATUS


def _name(i, names):
    return names[i] if 0 <= i < len(names) else str(i)


def payload_fields(data):
    """{"text": ...} when data is UTF-8 text, else {"hex": ...}; always "bytes"."""
    data = bytes(data)
    try:
        return {"text": data.decode("utf-8"), "bytes": len(data)}
    except UnicodeDecodeError:
        return {"hex": data.hex(), "bytes": len(data)}


def caddy_messages(data):
    """[[message name, values], ...] when the packet is CADDY messages (acomm.catalog.caddy), else None."""
    from acomm.catalog import caddy
    from acomm.errors import AcommError

    try:
        msgs = caddy.CATALOG.unpack(bytes(data))
    except (AcommError, ValueError, IndexError):
        return None
    return [[m.name, dict((k, round(v, 3) if isinstance(v, float) else v) for k, v in vals.items())]
            for m, vals in msgs] or None


def as_dict(ev):
    """The dict of a node event, or None for events a console does not show (caps)."""
    code = ev[0]
    if code == EV_RECEIVED:
        d = {"event": "received", "link": ev[E.LINK].name, "src": ev[E.SRC], "dst": ev[E.DST]}
        d.update(payload_fields(ev[E.DATA]))
        if len(ev) > E.AUTHED:
            d["authenticated"] = bool(ev[E.AUTHED])  # with a key: whether its frame's tag verified
        return d
    if code == EV_AVAILABILITY:
        return {"event": _name(ev[E.STATE], AVAIL_NAMES), "node": ev[E.NAME], "link": ev[E.LINK].name}
    if code == EV_STATUS:
        return {"event": "status", "link": ev[E.LINK].name, "id": ev[E.REQ_ID],
                "status": _name(ev[E.STATUS], STATUS_NAMES), "reason": ev[E.REASON] or "", "final": is_final(ev[E.STATUS])}
    if code == EV_RANGE_RECEIVED:
        return {"event": "range", "link": ev[E.LINK].name, "id": ev[E.REQ_ID],
                "ranges": dict((n, None if m is None else round(m, 1)) for n, m in zip(ev[E.NAMES], ev[E.METRES]))}
    if code == EV_PACKET_STATUS:
        return {"event": "packet_status", "id": ev[E.PID], "status": _name(ev[E.PACKET_STATUS], STATUS_NAMES),
                "reason": ev[E.PACKET_REASON] or "", "final": is_final(ev[E.PACKET_STATUS])}
    if code == EV_PACKET:
        d = {"event": "packet_received", "src": ev[E.PACKET_SRC], "dst": ev[E.PACKET_DST],
             "bytes": len(ev[E.PACKET_DATA])}
        if len(ev) > E.PACKET_AUTHED:
            d["authenticated"] = bool(ev[E.PACKET_AUTHED])
        caddy = caddy_messages(ev[E.PACKET_DATA])
        if caddy:
            d["caddy"] = caddy
        return d
    if code == EV_RELAY_STATUS:
        # a packet in this relay's custody ended here
        return {"event": "relay_status", "origin": ev[RELAY_ORIGIN], "id": ev[RELAY_PID],
                "status": _name(ev[RELAY_STATUS], STATUS_NAMES), "reason": ev[RELAY_REASON] or "", "final": True}
    if code == EV_REFUSED:
        link = ev[E.LINK]
        return {"event": "refused", "link": link.name if link is not None else None, "src": ev[E.REFUSED_SRC],
                "reason": ev[E.REFUSED_REASON]}
    return None


def _reason(d):
    return (": " + d["reason"]) if d.get("reason") else ""


def as_text(d):
    """One line for a person; None for what a terminal does not show (statuses on the way)."""
    e = d["event"]
    if e == "received":
        what = d["text"] if "text" in d else "%d bytes 0x%s" % (d["bytes"], d["hex"])
        return "received %s %s -> %s: %s%s" % (d["link"], d["src"], d["dst"], what,
                                               " (unauthenticated)" if d.get("authenticated") is False else "")
    if e in AVAIL_NAMES:
        return "%s %s on %s" % (e, d["node"], d["link"])
    if e == "status":
        if not d["final"]:
            return None
        return "status %s %d %s%s" % (d["link"], d["id"], d["status"], _reason(d))
    if e == "range":
        parts = ["%s %s" % (n, "no answer" if m is None else "%.1f m" % m) for n, m in d["ranges"].items()]
        return "range %s %d %s" % (d["link"], d["id"], ", ".join(parts))
    if e == "packet_status":
        if not d["final"]:
            return None
        return "packet %d %s%s" % (d["id"], d["status"], _reason(d))
    if e == "relay_status":
        return "relayed packet %d from %s %s here%s" % (d["id"], d["origin"], d["status"], _reason(d))
    if e == "packet_received":
        caddy = "".join("; CADDY %s %s" % (m[0], json.dumps(m[1], sort_keys=True)) for m in d.get("caddy", ()))
        return "received packet %s -> %s: %d bytes%s%s" % (d["src"], d["dst"], d["bytes"], caddy,
                                                           (", saved as " + d["saved"]) if d.get("saved") else "")
    if e == "refused":
        return "refused from %s%s: %s" % (d["src"], (" on " + d["link"]) if d["link"] else "", d["reason"])
    if e == "sent":
        return "sent %s %d to %s (%d bytes, priority %d%s)" % (d["link"], d["id"], d["dst"], d["bytes"], d["priority"],
                                                              ", ack" if d["ack"] else "")
    if e == "packet":
        if "what" in d:
            return "packet %d to %s: %s, queued" % (d["id"], d["dst"], d["what"])
        return "packet %d to %s: %d bytes from %s, queued" % (d["id"], d["dst"], d["bytes"], d["path"])
    if e == "ranging":
        return "ranging %s %d %s" % (d["link"], d["id"], d["dst"])
    if e == "progress":
        return None  # drawn as the status line
    if e == "error":
        return "error: " + d["error"]
    if e == "link_up":
        return "%s: %s on %s, up" % (d["link"], d["kind"], d["where"])
    if e == "ready":
        return "ready: node %s (%d) on %s; type help" % (d["node"], d["id"], ", ".join(d["links"]) or "no link")
    if e == "listening" or e == "store":
        return d["text"]
    if e in ("help", "report"):
        return "\n".join(d["lines"])
    if e == "draining":
        return "end of input: waiting for %d open request%s to end (Ctrl-C leaves now)" % (
            d["open"], "" if d["open"] == 1 else "s")
    if e == "stopped":
        return "stopped%s" % _reason(d)
    if e == "web_command":
        a = d["answer"]
        return "web: %s %s -> %d %s" % (d["by"], json.dumps(d["command"], sort_keys=True), d["code"],
                                        a.get("error") or json.dumps(a, sort_keys=True))
    if e == "web":
        return "console: %s" % d["url"]
    return json.dumps(d)


def progress_bar(done, total, width=20):
    """'[#####...............]  5/20' for done of total parts."""
    n = width * done // total if total else width
    return "[%s%s] %d/%d" % ("#" * n, "." * (width - n), done, total)


class Output:
    """Prints dicts as text or JSON lines, copies each to the log file with its time.

    On a terminal (text mode) a progress line is kept at the bottom and
    redrawn with \\r; a normal line first clears it."""

    def __init__(self, stream, json_lines=False, log=None, tty=None):
        self.stream = stream
        self.json = json_lines
        self.log = log
        self.tty = stream.isatty() if tty is None else tty
        self._bar = ""
        self._bar_id = None

    def emit(self, d):
        if self.log is not None:
            self.log.write(json.dumps(dict(d, t=round(time.time(), 3))) + "\n")
            self.log.flush()
        if d["event"] == "progress":
            self._progress(d)
            if not self.json:
                return
        if self.json:
            self._write(json.dumps(d))
            return
        if d["event"] == "packet_status" and d["final"] and d["id"] == self._bar_id:
            self._clear()  # the transfer is over: its bar goes
        text = as_text(d)
        if text is not None:
            self._write(text)

    def _clear(self):
        if self._bar:
            self.stream.write("\r" + " " * len(self._bar) + "\r")
        self._bar = ""
        self._bar_id = None

    def _write(self, line):
        if self._bar:
            self.stream.write("\r" + " " * len(self._bar) + "\r")
        self.stream.write(line + "\n")
        if self._bar:
            self.stream.write(self._bar)
        self.stream.flush()

    def _progress(self, d):
        if self.json or not self.tty:
            return
        bar = "packet %d %s sent, %d acknowledged" % (d["id"], progress_bar(d["sent"], d["count"]), d["acked"])
        pad = " " * max(0, len(self._bar) - len(bar))
        self._bar = bar
        self._bar_id = d["id"]
        self.stream.write("\r" + bar + pad + ("\r" + bar if pad else ""))
        self.stream.flush()
